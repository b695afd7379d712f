"""The machine handed to the method (``methods/protocol.py``): every method takes ``system``; without
one it fails with a message that says how to give it; the benchmark's cell builds each method with
its machine, and a user's class whose constructor takes no ``system`` as before."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from lcgym.data import Trial
from lcgym.leaderboard.runner import BenchConfig, run_cell
from lcgym.methods import CONTROLLERS, FeedbackOnly, PhysicalFeedforward
from lcgym.methods.pgnn import PGNN, PGNNConfig
from lcgym.methods.protocol import Controller, Cost, apply, build_method, given_system, load_method, takes_system
from lcgym.systems.flexarm import FLEXARM
from lcgym.systems.ix import IX
from lcgym.systems.ix import dynamics as ix
from lcgym.systems.ix.references import random_moves

TINY = {"seeds": (0,), "n_train": 1, "n_validation": 1, "duration": 4.0}

USER_METHODS = textwrap.dedent("""
    import numpy as np

    HANDED = []  # what each constructor was given, in order

    class Zero:
        name = "zero"
        def fit(self, trials):
            return self
        def feedforward(self, reference):
            return np.zeros_like(reference.positions)

    class Handed(Zero):
        def __init__(self, system=None):
            HANDED.append(("Handed", system))
            self.system = system

    class ByKeywords(Zero):
        def __init__(self, **options):
            HANDED.append(("ByKeywords", options.get("system")))

    class Plain(Zero):
        def __init__(self):
            HANDED.append(("Plain", None))

    class NoConstructor(Zero):
        pass
""")


def _trials() -> list[Trial]:
    r = random_moves("s0", np.random.default_rng(0), duration=2.0)
    return [Trial(t=r.t, ref=r.positions, pos=r.positions, u=np.zeros_like(r.positions), axes=ix.AXES)]


@pytest.mark.bad_input
@pytest.mark.parametrize("method", sorted(set(CONTROLLERS) - {"feedback"}))
def test_a_method_without_a_machine_says_how_to_give_it(method):
    cls = CONTROLLERS[method]
    with pytest.raises(ValueError, match=rf"{method}: give the machine, {cls.__name__}\(system='\w+'\) \(a name"):
        cls().fit(_trials())


@pytest.mark.bad_input
def test_the_message_names_the_other_way_where_there_is_one():
    with pytest.raises(ValueError, match=r"or the model, PhysicalFeedforward\(model=\.\.\.\)"):
        PhysicalFeedforward().fit(_trials())
    with pytest.raises(ValueError, match=r"BasicArmFeedforward\(system='flexarm'\).*or the structure"):
        CONTROLLERS["basic"]().fit(_trials())
    with pytest.raises(ValueError, match=r"PGNN: give the machine, PGNN\(system='ix'\).*PGNN\(physical=\.\.\.\)"):
        PGNN(PGNNConfig(max_epochs=1, threads=1)).fit(_trials())


def test_a_machine_by_name_or_as_a_system_is_stored_as_given_and_resolved_in_fit():
    trials = _trials()
    by_name = PhysicalFeedforward(system="ix-v1").fit(trials)
    given = PhysicalFeedforward(system=IX).fit(trials)
    assert by_name.system == "ix-v1" and by_name.system_ is IX and given.system is IX
    ref = random_moves("new", np.random.default_rng(1), duration=1.0)
    np.testing.assert_array_equal(by_name.feedforward(ref), given.feedforward(ref))
    assert FeedbackOnly(system="anything").system == "anything"  # taken, not needed
    assert given_system(FeedbackOnly(system="flexarm")) is FLEXARM


def test_every_built_in_method_takes_its_machine():
    assert all(takes_system(cls) for cls in CONTROLLERS.values())
    for name, cls in CONTROLLERS.items():
        method = build_method(name, IX, CONTROLLERS)
        assert type(method) is cls and method.system is IX


def test_the_cell_hands_its_machine_and_builds_a_class_without_one_as_before(tmp_path, monkeypatch):
    (tmp_path / "handed_methods.py").write_text(USER_METHODS)
    monkeypatch.syspath_prepend(str(tmp_path))
    import handed_methods

    assert [takes_system(getattr(handed_methods, c)) for c in ("Handed", "ByKeywords", "Plain", "NoConstructor")] \
        == [True, True, False, False]
    for system, machine in (("ix", IX), ("flexarm-v1", FLEXARM)):
        handed_methods.HANDED.clear()
        for c in ("Handed", "ByKeywords", "Plain", "NoConstructor"):
            method = f"handed_methods:{c}"
            rows, trace = run_cell(system, method, 0, BenchConfig(systems=(system,), methods=(method,), **TINY))
            assert {r["status"] for r in rows} == {"ok"}, rows[0].get("error")
        assert handed_methods.HANDED == [("Handed", machine), ("ByKeywords", machine), ("Plain", None)]


def test_a_users_class_is_wrapped_once_and_keeps_what_it_declares(tmp_path, monkeypatch):
    """A class that is no ``Controller`` comes back from ``load_method`` as one (``UserMethod``), of its
    name, constructor signature and class attributes; the built method forwards the contract to it."""
    (tmp_path / "duck_methods.py").write_text(textwrap.dedent("""
        import numpy as np
        from lcgym.methods import Cost

        class Duck:
            systems = ("ix",)
            relative_cost = 3.0
            def __init__(self, system=None):
                self.system = system
            def fit(self, trials):
                self.cost_, self.note_ = Cost(plant_trials=2), "quack"
                return self
            def feedforward(self, reference):
                return np.ones_like(reference.positions)
            def nn_contribution(self, reference):
                return 0.5 * np.ones_like(reference.positions)

        class Plain:
            def fit(self, trials):
                return self
            def feedforward(self, reference):
                return np.zeros_like(reference.positions)
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    cls = load_method("duck_methods:Duck", CONTROLLERS)
    assert issubclass(cls, Controller) and cls is load_method("duck_methods:Duck", CONTROLLERS)  # wrapped once
    assert (cls.__name__, cls.systems, cls.relative_cost, cls.uses_plant, takes_system(cls)) == ("Duck", ("ix",), 3.0,
                                                                                                False, True)
    duck = build_method("duck_methods:Duck", IX, CONTROLLERS)
    assert duck.system is IX and duck.cost_ == Cost() and duck.note_ == ""
    ref = random_moves("r", np.random.default_rng(0), duration=1.0)
    signals = apply(duck.fit(_trials()), None, [ref], ix.AXES)
    assert duck.cost_ == Cost(plant_trials=2) and duck.note_ == "quack"
    np.testing.assert_array_equal(signals.nn_contributions[0], 0.5)
    assert signals.offsets == [None]
    plain = build_method("duck_methods:Plain", IX, CONTROLLERS)
    assert plain.system is None and plain.nn_contribution(ref) is None and plain.reference_offset(ref) is None


def test_a_controller_must_give_its_feedforward():
    class NoFeedforward(Controller):
        pass

    with pytest.raises(TypeError, match="abstract method.*feedforward"):
        NoFeedforward()


def test_a_methods_machine_settings_are_typed_and_checked():
    """A machine's ``[benchmark.<method>]`` table becomes the method's own dataclass: the IX's
    values, the defaults where a machine sets none, and a key the method does not take named."""
    import dataclasses

    from lcgym.methods.pgnn.settings import COLLECT, PGNNProtocol
    from lcgym.methods.rl import NUM_ENVS, PASSES, RLConfig, RLMachineSettings
    from lcgym.systems.flexarm import FLEXARM
    from lcgym.systems.ix import IX

    assert RLMachineSettings.of(IX) == RLMachineSettings(passes=3.0, num_envs=8, agent_rate=50.0)
    assert RLConfig(passes=0.5).on(IX) == RLMachineSettings(passes=0.5, num_envs=8, agent_rate=50.0)
    assert RLMachineSettings.of(FLEXARM) == RLMachineSettings(passes=1.0, num_envs=4, agent_rate=0.0)
    assert PGNNProtocol.of(IX) == PGNNProtocol(collect="physical", filter_hz=None, constraint_configs=None)  # u as measured
    assert PGNNProtocol.of(FLEXARM) == PGNNProtocol(collect="physical", filter_hz=10.0, decimate=10)
    bare = dataclasses.replace(FLEXARM, settings={})
    assert RLMachineSettings.of(bare) == RLMachineSettings(PASSES, NUM_ENVS, 0.0) and PGNNProtocol.of(bare).collect == COLLECT
    typo = dataclasses.replace(FLEXARM, settings={"rl": {"pases": 2.0}, "pgnn": {"colect": "physical"}})
    with pytest.raises(ValueError, match=r"\[benchmark.rl\] has no setting pases"):
        RLMachineSettings.of(typo)
    with pytest.raises(ValueError, match=r"\[benchmark.pgnn\] has no setting colect"):
        PGNNProtocol.of(typo)
    with pytest.raises(ValueError, match="collect must be"):
        PGNNProtocol(collect="twice")
