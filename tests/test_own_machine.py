"""A user's machine as Python (``--system module:attr``): the README's one-axis example, run as the
README says, on a log with a hidden friction its model lacks; and the refusals of a bad spec.

The example is read from the README itself (the code block that starts with ``# my_axis.py``), so
the README's code cannot rot.
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym import systems
from lcgym.cli import main
from lcgym.references import AxisProfile, sample

README = Path(__file__).resolve().parents[1] / "README.md"
FS = 1000.0


def readme_example() -> str:
    blocks = re.findall(r"```python\n(# my_axis\.py.*?)```", README.read_text(), flags=re.S)
    assert len(blocks) == 1, "the README has one code block starting with '# my_axis.py'"
    return blocks[0]


@pytest.fixture()
def my_axis(tmp_path, monkeypatch):
    """The README's module in a fresh folder, that folder the current one (as a user runs it)."""
    code = readme_example()
    assert len(code.strip().splitlines()) < 30, "the README promises a complete example in under 30 lines"
    (tmp_path / "my_axis.py").write_text(code)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    sys.modules.pop("my_axis", None)


def _log(path: Path, machine: systems.System, friction: float) -> Path:
    """Moves of the carriage with force = the machine's model at its nominal parameters + a hidden
    Coulomb friction ``friction`` [N] (tanh-smoothed at 2 mm/s); the carriage follows the reference
    within 0.1 mm."""
    rng = np.random.default_rng(1)
    p = AxisProfile(0.0).dwell(0.5)
    while p.end_time < 40.0:
        p.move(float(rng.uniform(-0.4, 0.4)), float(rng.uniform(0.2, 0.5)), 2.0, 20.0).dwell(float(rng.uniform(0.2, 0.8)))
    ref = sample("log", [p], FS)
    x, v, a = ref.positions, ref.velocities, ref.accelerations
    nominal = machine.nominal_params().to_vector()
    u = machine.inverse_dynamics(nominal, x, v, a) + friction * np.tanh(v / 2e-3)
    u = u + rng.normal(0.0, 0.2, u.shape)  # N: the amplifier's noise
    pos = x + 1e-4 * np.sin(2 * math.pi * 0.3 * ref.t)[:, None]
    pd.DataFrame({"t": ref.t, "ref_x": x[:, 0], "pos_x": pos[:, 0], "u_x": u[:, 0]}).to_csv(path, index=False)
    return path


def test_readme_machine_is_diagnosed_and_the_friction_found(my_axis, capsys):
    machine = systems.get("my_axis:AXIS")
    assert machine.axis_names == ("x",) and machine.axes[0].kind == "prismatic" and machine.input_unit == "N"
    log = _log(my_axis / "log.csv", machine, friction=8.0)
    assert main(["diagnose", str(log), "--system", "my_axis:AXIS", "--add", "coulomb_friction@x"]) == 0
    out = capsys.readouterr().out
    first = re.search(r"  1\. (\S+)", out)
    assert first and first.group(1) == "coulomb_friction@x", out
    before, after = map(float, re.search(r"  x\s+([\d.]+)\s+([\d.]+)\s+-\d+%", out).groups())
    assert after < 0.5 * before, out
    assert "mm/s" in out  # a prismatic axis's parameters print in mm, not deg


def test_without_the_hidden_friction_nothing_is_claimed(my_axis, capsys):
    log = _log(my_axis / "log.csv", systems.get("my_axis:AXIS"), friction=0.0)
    assert main(["diagnose", str(log), "--system", "my_axis:AXIS"]) == 0
    assert "no missing effect found" in capsys.readouterr().out


@pytest.mark.bad_input
@pytest.mark.parametrize("spec, message", [
    ("no_such_module_xyz:AXIS", "cannot import module 'no_such_module_xyz'"),
    ("my_axis:NOPE", "module 'my_axis' has no 'NOPE'"),
    ("my_axis:math", "is a module, not a lcgym.systems.System"),
    ("my_axis:regressor", "calling it raised TypeError"),
])
def test_a_bad_module_attr_is_refused_in_one_line(my_axis, capsys, spec, message):
    log = _log(my_axis / "log.csv", systems.get("my_axis:AXIS"), friction=0.0)
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
