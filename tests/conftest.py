"""Suite-wide helpers: the hardening tally printed in the summary; a float64 torch fixture.

Tests that try bad input on purpose carry the marker ``bad_input``, tests that inject a fault
(a diverging plant, a killed writer, a raising controller) the marker ``fault``; each passed
case counts one. A test that knows better counts itself with the ``tally`` fixture
(``tally("bad_input", n)``, ``tally("rows_checked", n)``), e.g. per hypothesis example. The
summary prints the totals: every counted case ended with the clear error it asserts and
nothing lost.
"""

from collections import Counter

import pytest
import torch

LABELS = {"bad_input": "bad inputs tried", "fault": "faults injected", "rows_checked": "result rows checked"}
COUNTS: Counter = Counter()
_SELF_COUNTED: set[str] = set()


@pytest.fixture
def tally(request):
    """``tally(kind, n=1)``: count n cases of ``kind`` (one of ``LABELS``) for this test."""

    def add(kind: str, n: int = 1) -> None:
        if kind not in LABELS:
            raise ValueError(f"tally: unknown kind {kind!r}; known: {sorted(LABELS)}")
        COUNTS[kind] += n
        _SELF_COUNTED.add(request.node.nodeid)

    return add


def pytest_runtest_logreport(report):
    if report.when != "call" or not report.passed or report.nodeid in _SELF_COUNTED:
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
