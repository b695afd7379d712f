"""A learning method's base (``methods.bases``): ``METHOD@BASE``, the ``base`` column, the gain over
the base, and the rules that keep a learner from ending worse than its base (ILC's best trial, the
training-reference safeguard of the RBF expert, ILC transfer and the PGNN)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from lcgym.leaderboard.report import ranking
from lcgym.leaderboard.runner import BenchConfig, run_benchmark
from lcgym.leaderboard.store import read_results
from lcgym.methods import CONTROLLERS
from lcgym.methods.protocol import build_method, display_name, load_method, method_base, split_spec
from lcgym.methods.safeguard import dropped_note, keep_axes, mixed
from lcgym.systems.learning import best_trial

RAIL_ARM = Path(__file__).parent / "data" / "rail_arm" / "rail_arm.toml"


def test_method_at_base_is_parsed_and_normalized():
    assert split_spec("ilc@basic") == ("ilc", "basic") and split_spec("ilc") == ("ilc", None)
    assert display_name("ilc", "physical") == "ilc" and display_name("ilc", "basic") == "ilc@basic"
    config = BenchConfig(systems=("flexarm",), methods=("ilc@physical", "ilc", "ilc@basic"), seeds=(0,))
    assert config.methods == ("ilc", "ilc@basic")  # the default base is the id alone: one name per cell
    assert {m: method_base(m, CONTROLLERS) for m in ("ilc", "ilc@basic", "rl", "pgnn", "physical", "paper002-lcs")} \
        == {"ilc": "physical", "ilc@basic": "basic", "rl": "physical", "pgnn": "physical", "physical": "",
            "paper002-lcs": "basic"}
    assert build_method("rbf-expert@basic", "flexarm", CONTROLLERS).base == "basic"
    # a base that only the FlexArm has: the method's cells run there only
    both = BenchConfig(systems=("ix", "flexarm"), methods=("ilc", "ilc@basic"), seeds=(0,))
    assert [c[:2] for c in both.cells()] == [("ix-v1", "ilc"), ("flexarm-v1", "ilc"), ("flexarm-v1", "ilc@basic")]


@pytest.mark.bad_input
@pytest.mark.parametrize(("spec", "message"), [
    ("ilc@", "write METHOD@BASE"),
    ("@basic", "write METHOD@BASE"),
    ("ilc@nominal", "unknown base 'nominal'; bases: physical, basic"),
    ("physical@basic", "builds on no base"),
    ("paper002-lcs@physical", "builds on no base"),
])
def test_a_bad_base_is_refused_clearly(spec, message):
    with pytest.raises(ValueError, match=message):
        load_method(spec, CONTROLLERS)


@pytest.mark.bad_input
def test_basic_on_a_machine_without_it_is_refused():
    with pytest.raises(ValueError, match="runs on flexarm only"):
        BenchConfig(systems=("ix",), methods=("ilc@basic",))
    ilc = build_method("ilc@basic", "ix", CONTROLLERS)
    with pytest.raises(ValueError, match="nominal structure, which ix does not have"):
        ilc.fit([])


def test_best_trial_is_never_measured_worse_than_the_base_on_a_scored_axis():
    history = [np.array([1.0, 1.0, 5.0]), np.array([0.5, 1.1, 0.1]), np.array([0.8, 0.9, 9.0]),
               np.array([0.9, 0.95, 0.2])]
    assert best_trial(history, [0, 1]) == 2  # trial 1 is the lowest on axis 0 but worse than the base on axis 1
    assert best_trial(history, [0]) == 1
    assert best_trial([np.array([1.0]), np.array([2.0])], [0]) == 0  # none better: the base


def test_the_safeguard_rule_falls_back_per_axis_then_whole():
    base = np.array([[1.0, 1.0], [1.0, 1.0]])  # (references, scored axes)
    better = np.array([[0.5, 0.5], [0.6, 0.4]])
    kept, figures = keep_axes(base, better, lambda k: pytest.fail("no mixed run needed"), [0, 1], 2)
    assert kept.tolist() == [True, True] and set(figures) == {"base", "learned"}
    worse_on_one = np.array([[0.5, 1.2], [0.6, 0.4]])  # axis 1 worse on reference 0
    kept, figures = keep_axes(base, worse_on_one, lambda k: np.array([[0.7, 1.0], [0.8, 1.0]]), [0, 1], 2)
    assert kept.tolist() == [True, False] and "masked" in figures
    kept, _ = keep_axes(base, worse_on_one, lambda k: np.array([[0.7, 1.01], [0.8, 1.0]]), [0, 1], 2)
    assert kept.tolist() == [False, False]  # the mixed one still raised axis 1 (coupling): the base alone
    # an unscored axis keeps the learned signal only where every scored axis was better
    kept, _ = keep_axes(base, better, lambda k: None, [0, 1], 3)
    assert kept.tolist() == [True, True, True]
    f, o = mixed((np.zeros((2, 2)), None), (np.ones((2, 2)), np.ones((2, 2))), np.array([True, False]))
    assert f.tolist() == [[1, 0], [1, 0]] and o.tolist() == [[1, 0], [1, 0]]


def test_a_learned_signal_that_drives_the_plant_out_is_dropped_not_the_cells_failure():
    """The safeguard's run of a learned feedforward that leaves the plant's safe range is the method's
    failed trial: counted infinitely worse, dropped, and said; the base's own failing run is raised."""
    from lcgym import systems
    from lcgym.methods.safeguard import Safeguard
    from lcgym.systems import SimulationDiverged

    machine = systems.resolve("flexarm")
    bench = machine.system.make_bench()
    refs = bench.references("train", 0, 2, 6.0)
    quiet = lambda r: (np.zeros_like(r.positions), None)  # noqa: E731
    wild = lambda r: (np.zeros_like(r.positions), np.full_like(r.positions, 2.0))  # noqa: E731  the motors 2 rad away
    guard = Safeguard(machine.system)
    kept = guard.choose(bench.plant, refs, quiet, wild)
    assert not kept.any() and guard.diverged_ >= len(refs)
    note = dropped_note("x", kept, refs[0].axes, guard.references_worse_, len(refs), diverged=guard.diverged_)
    assert "of its runs left the plant's safe range" in note
    with pytest.raises(SimulationDiverged):
        Safeguard(machine.system).choose(bench.plant, refs, wild, quiet)


def _bare(tmp_path: Path) -> Path:
    """The rail arm's machine file without its hidden friction: its physical model is exact."""
    folder = tmp_path / "bare"
    folder.mkdir()
    shutil.copy(RAIL_ARM.parent / "rail_arm.urdf", folder)
    text = RAIL_ARM.read_text().split("[[hidden]]")[0]
    (folder / "bare.toml").write_text(text)
    return folder / "bare.toml"


def _validation(out: Path):
    table = ranking(read_results(out))
    return table[(table["signal"] == "tracking_error") & (table["period"] == "all")].pivot_table(
        index="method", columns="axis", values="RMS")


def test_ilc_on_a_bare_urdf_machine_is_at_or_below_its_physical_model(tmp_path):
    """A machine with no hidden effect (its physical model is exact up to the fit): ILC starts from that
    model and keeps its best measured trial, so on the references it learns (and is scored) on it ends
    at or below the model on every axis (issue 48: it ended 0.055 deg against 0.040 before)."""
    out = tmp_path / "r.csv"
    config = BenchConfig(systems=(str(_bare(tmp_path)),), methods=("physical", "ilc"), seeds=(0,), n_train=2,
                         n_validation=2, duration=6.0, budget=0.5)
    assert run_benchmark(config, out, progress=False)["cells_failed"] == 0
    rms = _validation(out)
    assert (rms.loc["ilc"] <= rms.loc["physical"]).all(), rms
    rows = read_results(out)
    assert set(rows.loc[rows["method"] == "ilc", "base"]) == {"physical"}
    assert set(rows.loc[rows["method"] == "physical", "base"]) == {""}


def test_the_pgnn_on_a_prismatic_machine_stays_near_its_physical_model(tmp_path):
    """The rail arm (a prismatic rail, a shoulder, an elbow with a hidden friction): the PGNN, whose
    network ended 10-13x worse than the physical model on the rail (issue 48), is kept by its
    safeguard within 1.05x of that model or better on every axis."""
    out = tmp_path / "r.csv"
    config = BenchConfig(systems=(str(RAIL_ARM),), methods=("physical", "pgnn"), seeds=(0,), n_train=2,
                         n_validation=2, duration=6.0, budget=0.5)
    assert run_benchmark(config, out, progress=False)["cells_failed"] == 0
    rms = _validation(out)
    assert (rms.loc["pgnn"] <= 1.05 * rms.loc["physical"]).all(), rms


def test_the_pgnn_is_judged_on_three_training_references_or_more():
    """On two short IX runs (``lcgym bench --quick``'s, seed 0) pgnn-ls lowers the tracking error of
    both training references and ends 1.3x or more above the base on new ones (the safeguard as it
    ran, ``paper000-pgnn``'s: ``min_judged`` 0); judged on fewer than three, the least-squares model
    acts and the row says so."""
    from lcgym import systems
    from lcgym.methods.pgnn.method import PGNNLSFeedforward
    from lcgym.methods.protocol import evaluate

    bench = systems.resolve("ix").bench()
    refs = {s: bench.references(s, 0, 2, 20.0) for s in ("train", "validation")}
    train = bench.run(refs["train"])

    def validation_rms(method) -> np.ndarray:
        _, out = evaluate(method, bench, train, {"validation": refs["validation"]})
        return np.sqrt(np.mean(np.concatenate([t.error for t in out["validation"].trials]) ** 2, axis=0))

    base = validation_rms(build_method("physical", "ix", CONTROLLERS))
    judged = PGNNLSFeedforward(system="ix", budget=0.5)
    np.testing.assert_allclose(validation_rms(judged), base)
    assert not judged.part_kept_.any() and not judged.net_kept_.any()
    assert "judged on 3 training references or more, here 2" in judged.note_
    as_it_ran = PGNNLSFeedforward(system="ix", budget=0.5)
    as_it_ran.min_judged = 0
    assert validation_rms(as_it_ran)[0] > 1.3 * base[0] and as_it_ran.net_kept_.all()
