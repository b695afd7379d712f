"""A memo of an expensive function of arrays, alive only inside a block.

A diagnosis evaluates one machine's regressor on the same kinematics, and refits one model on the
same filtered design, tens of times; a benchmark cell evaluates its bases on each reference again
and again. ``ArrayMemo`` keeps the last results while an ``active()`` block runs and drops them when
it ends, so that a long-lived process holds no hundreds of MB between uses. One class serves a
machine's regressors (``System.caching``) and the model's filtered designs
(``physics.preprocessing.reduction_memo``).
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from collections.abc import Callable, Hashable
from contextlib import contextmanager

import numpy as np


class ArrayMemo:
    """The last ``size`` results of a function of arrays, keyed by the arrays, kept only while an
    ``active()`` block runs and returned read-only.

    An array is known by its bytes, shape and dtype; with ``by_identity``, a read-only one (a
    result of a memo) by its identity, the entry holding it so that the identity cannot pass to
    another array. Calls whose first array has fewer than ``min_rows`` rows are computed, not kept
    (hashing a short array costs about as much as computing on it).
    """

    def __init__(self, size: int = 3, min_rows: int = 0, by_identity: bool = False):
        self.size = size
        self.min_rows = min_rows
        self.by_identity = by_identity
        self._store: OrderedDict | None = None

    def _key(self, a: np.ndarray | None) -> Hashable:
        if a is None:
            return None
        a = np.asarray(a)
        if self.by_identity and not a.flags.writeable:
            return ("id", id(a), a.shape)
        return (hashlib.blake2b(np.ascontiguousarray(a).view(np.uint8), digest_size=16).digest(), a.shape, a.dtype.str)

    def get(self, compute: Callable[[], np.ndarray], *arrays: np.ndarray | None, extra: Hashable = ()) -> np.ndarray:
        """``compute()``, or the result kept for the same ``arrays`` and ``extra`` (what else the
        result depends on)."""
        if self._store is None or np.shape(arrays[0])[0] < self.min_rows:
            return compute()
        key = (*(self._key(a) for a in arrays), extra)
        if key in self._store:
            self._store.move_to_end(key)
            return self._store[key][0]
        result = compute()
        result.flags.writeable = False
        self._store[key] = (result, arrays)  # the inputs held: their identities stay theirs
        while len(self._store) > self.size:
            self._store.popitem(last=False)
        return result

    def clear(self) -> None:
        """Drop the results kept (an active block goes on keeping new ones)."""
        if self._store is not None:
            self._store.clear()

    @contextmanager
    def active(self, size: int | None = None):
        """Keep results while the block runs (nested blocks share the outer one's store); ``size``:
        keep this many for the block's duration instead of ``self.size`` (a benchmark cell keeps
        every reference's regressor)."""
        outer, outer_size = self._store, self.size
        self._store = OrderedDict() if outer is None else outer
        if size is not None:
            self.size = max(int(size), outer_size)
        try:
            yield
        finally:
            self._store, self.size = outer, outer_size
