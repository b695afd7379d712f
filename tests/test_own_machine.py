"""A user's machine as Python (``--system module:attr``): the docs' one-axis example
(``docs/own-machine.md``), run as the page says, on the page's log with a hidden friction its model
lacks; and the refusals of a bad spec.

The example is read from the page itself (the code blocks that start with ``# my_axis.py`` and
``# make_log.py``), so the page's code cannot rot.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym import systems
from lcgym.cli import main

PAGE = Path(__file__).resolve().parents[1] / "docs" / "own-machine.md"
FS = 1000.0


def readme_example() -> str:
    blocks = re.findall(r"```python\n(# my_axis\.py.*?)```", PAGE.read_text(), flags=re.S)
    assert len(blocks) == 1, "docs/own-machine.md has one code block starting with '# my_axis.py'"
    return blocks[0]


@pytest.fixture()
def my_axis(tmp_path, monkeypatch):
    """The page's module in a fresh folder, that folder the current one (as a user runs it)."""
    code = readme_example()
    assert len(code.strip().splitlines()) < 30, "the page promises a complete example in under 30 lines"
    (tmp_path / "my_axis.py").write_text(code)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    sys.modules.pop("my_axis", None)


def readme_log_maker() -> str:
    blocks = re.findall(r"```python\n(# make_log\.py.*?)```", PAGE.read_text(), flags=re.S)
    assert len(blocks) == 1, "docs/own-machine.md has one code block starting with '# make_log.py'"
    return blocks[0]


def _log(folder: Path, friction: float) -> Path:
    """The page's log of the carriage (``make_log.py``) with its ``FRICTION`` set to ``friction`` [N]."""
    code = readme_log_maker()
    assert "FRICTION = 8.0" in code
    exec(compile(code.replace("FRICTION = 8.0", f"FRICTION = {friction!r}"), "docs/own-machine.md make_log.py", "exec"),
         {"__name__": "make_log"})
    return folder / "log.csv"


def test_readme_machine_is_diagnosed_and_the_friction_found(my_axis, capsys):
    machine = systems.get("my_axis:AXIS")
    assert machine.axis_names == ("x",) and machine.axes[0].kind == "prismatic" and machine.input_unit == "N"
    log = _log(my_axis, friction=8.0)
    assert main(["diagnose", str(log), "--system", "my_axis:AXIS", "--add", "coulomb_friction@x"]) == 0
    out = capsys.readouterr().out
    first = re.search(r"  1\. (\S+)", out)
    assert first and first.group(1) == "coulomb_friction@x", out
    before, after = map(float, re.search(r"  x\s+([\d.]+)\s+([\d.]+)\s+-\d+%", out).groups())
    assert after < 0.5 * before, out
    assert "mm/s" in out  # a prismatic axis's parameters print in mm, not deg


def test_without_the_hidden_friction_nothing_is_claimed(my_axis, capsys):
    log = _log(my_axis, friction=0.0)
    assert main(["diagnose", str(log), "--system", "my_axis:AXIS"]) == 0
    assert "no missing effect found" in capsys.readouterr().out


@pytest.mark.bad_input
@pytest.mark.parametrize("spec, message", [
    ("no_such_module_xyz:AXIS", "cannot import module 'no_such_module_xyz'"),
    ("my_axis:NOPE", "module 'my_axis' has no 'NOPE'"),
    ("my_axis:math", "is an object of type module, not a lcgym.systems.System"),
    ("my_axis:regressor", "calling it raised TypeError"),
])
def test_a_bad_module_attr_is_refused_in_one_line(my_axis, capsys, spec, message):
    log = _log(my_axis, friction=0.0)
    listing = sorted(p.name for p in my_axis.iterdir())
    assert main(["diagnose", str(log), "--system", spec]) == 1
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert sorted(p.name for p in my_axis.iterdir()) == listing  # nothing written


@pytest.mark.bad_input
def test_a_module_that_raises_on_import_is_refused(tmp_path, monkeypatch, capsys):
    (tmp_path / "broken_machine.py").write_text("raise RuntimeError('my machine file is broken')\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    log = tmp_path / "log.csv"
    pd.DataFrame({"t": np.arange(5) / FS, "pos_x": 0.0, "u_x": 0.0}).to_csv(log, index=False)
    assert main(["diagnose", str(log), "--system", "broken_machine:AXIS"]) == 1
    assert "RuntimeError: my machine file is broken" in capsys.readouterr().err
    sys.modules.pop("broken_machine", None)


def test_from_regressor_derives_the_mass_matrix_and_the_torch_path():
    import torch

    def regressor(q, qd, qdd):  # two axes, coupled inertia: M = [[a + b, b], [b, b]]
        X = np.zeros((q.shape[0], 2, 2))
        X[:, 0, 0], X[:, 0, 1], X[:, 1, 1] = qdd[:, 0], qdd[:, 0] + qdd[:, 1], qdd[:, 0] + qdd[:, 1]
        return X

    m = systems.System.from_regressor("two", ["a1", "a2"], {"a": 2.0, "b": 0.5}, regressor, positive=("a", "b"))
    M = m.mass_matrix(np.array([2.0, 0.5]), np.zeros((1, 2)))
    np.testing.assert_allclose(M[0], [[2.5, 0.5], [0.5, 0.5]])
    p = torch.tensor([2.0, 0.5], dtype=torch.float64, requires_grad=True)
    u = m.inverse_dynamics(p, np.zeros((1, 2)), np.zeros((1, 2)), np.array([[1.0, 0.0]]))
    u.sum().backward()
    np.testing.assert_allclose(p.grad.numpy(), [1.0, 2.0])
    with pytest.raises(ValueError, match="regressor returned shape"):
        systems.System.from_regressor("bad", ["a1"], {"a": 1.0}, lambda q, qd, qdd: np.zeros((3, 3))).regressor(
            None, np.zeros((2, 1)), np.zeros((2, 1)), np.zeros((2, 1)))


@pytest.mark.bad_input
@pytest.mark.parametrize("build, message", [
    (lambda: systems.Axis("x", "linear"), "kind must be 'revolute' or 'prismatic'"),
    (lambda: systems.Axis("x@1"), "without '@'"),
    (lambda: systems.System.from_regressor("m", ["a", "a"], {"p": 1.0}, lambda q, qd, qdd: qdd[..., None]),
     "axis names must be unique"),
    (lambda: systems.System.from_regressor("m", ["a"], {"p": 1.0}, lambda q, qd, qdd: qdd[..., None], positive=("mass",)),
     "positive names ['mass'] are not parameters"),
    (lambda: systems.System.from_regressor("m", ["a"], {"p": 1.0}, lambda q, qd, qdd: qdd[..., None], fs=-1.0),
     "fs must be > 0"),
    (lambda: systems.get("crane"), "unknown machine 'crane'"),
])
def test_a_machine_described_wrongly_is_refused(build, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        build()


def test_a_machine_binds_effects_to_its_own_axes():
    machine = systems.System.from_regressor("m", [systems.Axis("x", "prismatic")], {"m": 1.0},
                                            lambda q, qd, qdd: qdd[..., None])
    assert machine.effect("coulomb_friction@x", Fc=2.0).index == 0
    with pytest.raises(ValueError, match="does not apply to a prismatic axis"):
        machine.effect("cable_drape@x")
    with pytest.raises(ValueError, match="m has no axis 'y'"):
        machine.effect("coulomb_friction@y")


@pytest.mark.bad_input
@pytest.mark.parametrize("regressor, message", [
    (lambda q, qd, qdd: np.stack([qdd / 0.0 * 0.0, qd], axis=-1), "the regressor returned nan at sample 0, axis x"),
    (lambda q, qd, qdd: 1 / 0, "the regressor raised ZeroDivisionError: division by zero"),
])
def test_a_user_regressor_that_fails_is_named_in_one_line(tmp_path, monkeypatch, capsys, regressor, message):
    machine = systems.System.from_regressor("bad", [systems.Axis("x", "prismatic")], {"m": 1.0, "d": 1.0}, regressor)
    module = tmp_path / "bad_machine.py"
    module.write_text("")
    monkeypatch.syspath_prepend(str(tmp_path))
    import importlib

    mod = importlib.import_module("bad_machine")
    monkeypatch.setattr(mod, "AXIS", machine, raising=False)
    t = np.arange(20_000) / 1000.0
    log = tmp_path / "log.csv"
    pd.DataFrame({"t": t, "pos_x": np.sin(t), "u_x": np.cos(t)}).to_csv(log, index=False)
    with np.errstate(all="ignore"):
        assert main(["diagnose", str(log), "--system", "bad_machine:AXIS"]) == 1
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    sys.modules.pop("bad_machine", None)
