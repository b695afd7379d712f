"""Bad user controllers, on purpose: each fails its own cell with the reason, the others run.

A benchmark method from user code (``module:Class``, see ``lcgym.methods.protocol``) may raise,
return the wrong shape, dtype or NaN, take too long (the per-cell time limit), or drive the plant
unstable. Each case must end as one ``failed`` row whose ``error`` names the fault, while the
``feedback`` cell beside it gives ``ok`` rows with finite numbers; no trace of the failed cell is
written and no NaN reaches the leaderboard. Methods that cannot be loaded are refused before any
cell runs.
"""

import textwrap
import time

import numpy as np
import pytest

from lcgym.leaderboard.report import format_text
from lcgym.leaderboard.runner import BenchConfig, run_benchmark
from lcgym.leaderboard.store import read_results

TINY = {"systems": ("ix",), "seeds": (0,), "n_train": 1, "n_validation": 1, "duration": 4.0}
METRICS = ["MA", "RMS", "Inf"]


BAD_CONTROLLERS = textwrap.dedent("""
    import numpy as np

    class Raises:
        name = "raises"
        def fit(self, trials):
            raise RuntimeError("my controller is broken")
        def feedforward(self, reference):
            return None

    class WrongShape:
        name = "wrong-shape"
        def fit(self, trials):
            return self
        def feedforward(self, reference):
            return np.zeros(3)

    class Good:
        name = "good"
        def fit(self, trials):
            return self
        def feedforward(self, reference):
            return np.zeros_like(reference.positions)

    class NaNs(Good):
        def feedforward(self, reference):
            f = np.zeros_like(reference.positions)
            f[len(f) // 2, 1] = np.nan
            return f

    class WrongDtype(Good):
        def feedforward(self, reference):
            return np.full(reference.positions.shape, "volts")

    class ReturnsNone(Good):
        def feedforward(self, reference):
            return None

    class NumpyRaises(Good):
        def feedforward(self, reference):
            return np.linalg.inv(reference.positions)  # raised inside numpy's Python code

    class Complex(Good):
        def feedforward(self, reference):
            return np.zeros(reference.positions.shape, dtype=complex)

    class Transposed(Good):
        def feedforward(self, reference):
            return np.zeros_like(reference.positions).T

    class NoFeedforward:
        def fit(self, trials):
            return self

    class HugeOffset(Good):  # the FlexArm's motor reference 2 rad away: the plant leaves its safe range
        def reference_offset(self, reference):
            return np.full(reference.positions.shape, 2.0)

    class SlowFit(Good):
        def fit(self, trials):
            import time
            time.sleep(30)
            return self

    class SlowFeedforward(Good):
        def feedforward(self, reference):
            while True:
                pass
""")


def test_user_controllers_failures_are_recorded_and_others_run(tmp_path, monkeypatch):
    (tmp_path / "my_ctrl.py").write_text(BAD_CONTROLLERS)
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "r.csv"
    config = BenchConfig(methods=("my_ctrl:Raises", "my_ctrl:WrongShape", "my_ctrl:Good", "feedback"), **TINY)
    summary = run_benchmark(config, out, progress=False)
    df = read_results(out)
    assert summary["cells_failed"] == 2
    errors = df[df.status == "failed"].set_index("method")["error"]
    assert "my controller is broken" in errors["my_ctrl:Raises"]
    assert "shape" in errors["my_ctrl:WrongShape"]
    assert (df[df.method == "my_ctrl:Good"]["status"] == "ok").all()
    assert "failed cells" in format_text(df)


@pytest.mark.bad_input
@pytest.mark.parametrize(("method", "message"), [
    ("my_ctrl:Raises", "RuntimeError in fit at my_ctrl.py:7: my controller is broken"),
    ("my_ctrl:WrongShape", "ValueError in feedforward of train-0-0: feedforward for train-0-0 has shape (3,), expected"),
    ("my_ctrl:NumpyRaises", "LinAlgError in feedforward of train-0-0 at my_ctrl.py:"),  # the user's line, not numpy's
    ("my_ctrl:NaNs", "contains NaN or inf, first at sample"),
    ("my_ctrl:WrongDtype", "feedforward for train-0-0 must be real numbers, got dtype <U5"),
    ("my_ctrl:ReturnsNone", "feedforward for train-0-0 must be real numbers, got dtype object: None"),
    ("my_ctrl:Complex", "must be real numbers, got dtype complex128"),
    ("my_ctrl:Transposed", "has shape (2, "),
    ("my_ctrl:SlowFit", "CellTimeout: the cell ran past its time limit of 1.5 s, in fit"),
    ("my_ctrl:SlowFeedforward", "CellTimeout: the cell ran past its time limit of 1.5 s, in feedforward of"),
])
def test_bad_user_controller_fails_its_cell_alone(tmp_path, monkeypatch, tally, method, message):
    """Each bad controller gets one failed row naming the fault; the good method beside it runs; the
    slow ones are stopped by the per-cell time limit within a few seconds; no trace is left."""
    (tmp_path / "my_ctrl.py").write_text(BAD_CONTROLLERS)
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "r.csv"
    t0 = time.perf_counter()
    summary = run_benchmark(BenchConfig(methods=(method, "feedback"), **TINY), out, progress=False, timeout=1.5)
    assert time.perf_counter() - t0 < 20
    df = read_results(out)
    failed = df[df.method == method]
    assert summary["cells_failed"] == 1 and len(failed) == 1 and (failed.status == "failed").all()
    assert message in failed.error.iloc[0], failed.error.iloc[0]
    ok = df[df.method == "feedback"]
    assert len(ok) == 8 and (ok.status == "ok").all() and np.isfinite(ok[METRICS].to_numpy()).all()
    assert failed[METRICS].isna().all(axis=None)  # no number for the failed cell, not a NaN among numbers
    assert not any((tmp_path / "r.csv.traces").rglob("*my_ctrl*"))
    tally("bad_input")
    tally("rows_checked", len(df))


@pytest.mark.fault
def test_a_diverging_plant_fails_its_cell_with_the_state_and_never_gives_nan_rows(tmp_path, monkeypatch, tally):
    (tmp_path / "my_ctrl.py").write_text(BAD_CONTROLLERS)
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "r.csv"
    config = BenchConfig(methods=("my_ctrl:HugeOffset", "basic"), **{**TINY, "systems": ("flexarm",)})
    summary = run_benchmark(config, out, progress=False)
    df = read_results(out)
    failed = df[df.method == "my_ctrl:HugeOffset"]
    assert summary["cells_failed"] == 1 and len(failed) == 1 and failed.status.iloc[0] == "failed"
    assert "SimulationDiverged" in failed.error.iloc[0] and "left its safe range at t =" in failed.error.iloc[0]
    assert "load angles" in failed.error.iloc[0]  # the state at which it diverged
    ok = df[df.status == "ok"]
    assert len(ok) and np.isfinite(ok[METRICS].to_numpy()).all()
    tally("fault")
    tally("rows_checked", len(df))


@pytest.mark.bad_input
def test_bench_refuses_a_bad_timeout(tmp_path):
    with pytest.raises(ValueError, match="timeout must be > 0"):
        run_benchmark(BenchConfig(methods=("feedback",), **TINY), tmp_path / "r.csv", progress=False, timeout=0)


@pytest.mark.bad_input
def test_unknown_method_and_system_refused(tmp_path, monkeypatch):
    (tmp_path / "my_ctrl.py").write_text(BAD_CONTROLLERS)
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ValueError, match="unknown method"):
        BenchConfig(methods=("magic",), **TINY)
    with pytest.raises(ValueError, match="cannot import"):
        BenchConfig(methods=("no_such_module_xyz:Thing",), **TINY)
    with pytest.raises(ValueError, match="has no 'Missing'"):
        BenchConfig(methods=("my_ctrl:Missing",), **TINY)
    with pytest.raises(ValueError, match="NoFeedforward lacks feedforward"):
        BenchConfig(methods=("my_ctrl:NoFeedforward",), **TINY)
    with pytest.raises(ValueError, match="unknown system"):
        BenchConfig(**{**TINY, "systems": ("crane",)})

