"""``physics.memo.ArrayMemo``: what it keeps, for how long, and by what it knows an array; and
``physics.workspace``, where a process keeps every such cache."""

import numpy as np
import pytest

from lcgym.physics.memo import ArrayMemo
from lcgym.physics.workspace import WORKSPACE, Workspace


def _counted():
    calls = []

    def compute(x):
        calls.append(1)
        return x * 2.0

    return calls, compute


def test_keeps_results_only_inside_its_block_and_read_only():
    memo, (calls, f) = ArrayMemo(size=2), _counted()
    x = np.arange(6.0)
    memo.get(lambda: f(x), x)
    memo.get(lambda: f(x), x)
    assert len(calls) == 2  # outside a block: computed each time
    with memo.active():
        first = memo.get(lambda: f(x), x)
        again = memo.get(lambda: f(x.copy()), x.copy())  # same bytes: kept
        assert again is first and not first.flags.writeable and len(calls) == 3
        other = memo.get(lambda: f(x), x, extra=("another",))
        assert other is not first and len(calls) == 4
    memo.get(lambda: f(x), x)
    assert len(calls) == 5


def test_drops_the_oldest_beyond_its_size_and_a_block_may_widen_it():
    memo, (calls, f) = ArrayMemo(size=2), _counted()
    xs = [np.full(3, float(i)) for i in range(3)]
    with memo.active():
        for x in xs:
            memo.get(lambda x=x: f(x), x)
        memo.get(lambda: f(xs[0]), xs[0])  # evicted: computed again
        assert len(calls) == 4
    with memo.active(size=3):
        for x in xs + xs:
            memo.get(lambda x=x: f(x), x)
        assert len(calls) == 7 and memo.size == 3
    assert memo.size == 2


def test_short_arrays_are_computed_and_read_only_ones_known_by_identity():
    memo, (calls, f) = ArrayMemo(min_rows=10), _counted()
    short = np.ones(5)
    with memo.active():
        memo.get(lambda: f(short), short)
        memo.get(lambda: f(short), short)
    assert len(calls) == 2
    memo, (calls, f) = ArrayMemo(by_identity=True), _counted()
    a = np.ones(4)
    a.flags.writeable = False
    b = np.ones(4)
    b.flags.writeable = False
    with memo.active():
        memo.get(lambda: f(a), a)
        memo.get(lambda: f(a), a)
        memo.get(lambda: f(b), b)  # equal bytes, another array: known by identity, computed
        assert len(calls) == 2
        with pytest.raises(ValueError):
            memo.get(lambda: f(a), a)[0] = 1.0  # what it returns is read-only


def test_a_workspace_makes_each_slot_once_and_clear_empties_them_all():
    space, (calls, f) = Workspace(), _counted()
    memo = space.slot("m", lambda: ArrayMemo(size=4))
    assert space.slot("m", lambda: ArrayMemo(size=1)) is memo  # made once: the second maker is not called
    models = space.slot("models", dict)
    x = np.arange(3.0)
    with memo.active():
        memo.get(lambda: f(x), x)
        models["fitted"] = object()
        space.clear()
        memo.get(lambda: f(x), x)  # emptied: computed again, and kept again
        memo.get(lambda: f(x), x)
    assert len(calls) == 2 and models == {} and space.names() == ["m", "models"]


def test_the_caches_of_lcgym_live_in_its_workspace():
    """Control for the module globals it replaced: using a cache makes its slot in ``WORKSPACE``."""
    from lcgym.physics.lti import discretize_foh

    discretize_foh(np.array([[0.0, 1.0], [-1.0, -0.1]]), np.array([[0.0], [1.0]]), 1e-3)
    assert "physics.lti.foh" in WORKSPACE.names()
