"""Suite-wide helpers: the suite on all cores; the hardening tally printed in the summary; a float64
torch fixture.

The suite runs on pytest-xdist's workers (``-n auto --dist loadfile`` in ``pyproject.toml``): one
per core, at most ``MAX_WORKERS``, each taking whole test files, so a module's fixtures are built
once. A worker runs torch and numba on one thread: two workers of two threads each on two cores
slow torch 10-100x. ``-n 0`` runs the suite in this process, as before.

Tests that try bad input on purpose carry the marker ``bad_input``, tests that inject a fault
(a diverging plant, a killed writer, a raising controller) the marker ``fault``; each passed
case counts one. A test that knows better counts itself with the ``tally`` fixture
(``tally("bad_input", n)``, ``tally("rows_checked", n)``), e.g. per hypothesis example. The
summary prints the totals: every counted case ended with the clear error it asserts and
nothing lost. The counts travel with each test's report (its ``user_properties``), so the
summary adds up the workers' tests.
"""

import os
from collections import Counter

if os.environ.get("PYTEST_XDIST_WORKER"):  # before numpy, numba and torch read them
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ.setdefault(var, "1")

import pytest  # noqa: E402
import torch  # noqa: E402

MAX_WORKERS = 4  # each worker holds torch, numba's kernels and a test's plant: about 1.5 GB
LABELS = {"bad_input": "bad inputs tried", "fault": "faults injected", "rows_checked": "result rows checked"}
COUNTS: Counter = Counter()
TALLY = "lcgym_tally"  # the user_properties key of a self-counted test's counts


def pytest_xdist_auto_num_workers(config):
    """``-n auto``: one worker per core this process may use, at most ``MAX_WORKERS``."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1  # macOS lacks it
    return max(1, min(cores, MAX_WORKERS))


def pytest_configure(config):
    if os.environ.get("PYTEST_XDIST_WORKER"):
        torch.set_num_threads(1)


@pytest.fixture
def tally(request):
    """``tally(kind, n=1)``: count n cases of ``kind`` (one of ``LABELS``) for this test."""
    counts = {}
    request.node.user_properties.append((TALLY, counts))

    def add(kind: str, n: int = 1) -> None:
        if kind not in LABELS:
            raise ValueError(f"tally: unknown kind {kind!r}; known: {sorted(LABELS)}")
        counts[kind] = counts.get(kind, 0) + n

    return add


def pytest_runtest_logreport(report):
    """Count a passed test's cases: in the process that prints the summary (xdist's controller, or
    the only one), where every test's report arrives."""
    if os.environ.get("PYTEST_XDIST_WORKER") or report.when != "call" or not report.passed:
        return
    counted = [counts for key, counts in report.user_properties if key == TALLY and counts]
    if counted:
        for counts in counted:
            COUNTS.update(counts)
        return
    for kind in ("bad_input", "fault"):
        if kind in report.keywords:
            COUNTS[kind] += 1


def pytest_terminal_summary(terminalreporter):
    if COUNTS:
        parts = ", ".join(f"{COUNTS[k]} {label}" for k, label in LABELS.items())
        terminalreporter.write_line(f"lcgym hardening: {parts}; each ended with a clear error and nothing lost")


@pytest.fixture
def float64_torch():
    """Double precision for autograd checks, restored afterwards (other tests train float32 nets)."""
    before = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    yield
    torch.set_default_dtype(before)
