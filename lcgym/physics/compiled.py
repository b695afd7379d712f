"""Settings of lcgym's compiled (numba) kernels: ``Kernels``, the decorator every module compiles
its kernels with (numba's ``njit(cache=True)``, cached in a folder of its own sources, the one
place that sets numba's cache folder), the fast-math flags of those that use them (the IX's and
the URDF plant's; the FlexArm's kernels run without), and ``in_row_blocks``, which runs a
row-wise kernel on blocks of rows in numba's threads.

The kernels themselves live with their machines (``systems/ix/kernel.py``, ``systems/ix/compiled.py``,
``systems/flexarm/*.py``, ``systems/urdf_plant.py``); they call the same ``register_jitable``
equations as the numpy and torch paths (no second implementation).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from numba.core.options import DefaultOptions

# LLVM fast-math flags for the kernels: fused multiply-add, reciprocals, reassociation. Not
# 'nnan'/'ninf': the plant's divergence check must still see NaN and inf. Results stay
# deterministic on one machine; they may differ in the last bits between CPUs.
FASTMATH = {"contract", "arcp", "reassoc", "nsz", "afn"}

# Kernels that allocate nothing compile without numba's runtime (its reference counts): every array
# a function passes on otherwise costs two atomic operations, which made the URDF plant's rigid
# body 3x slower per call (``rigid_body``). numba's ``_nrt`` option; an empty set where a numba
# no longer has it.
NO_REFCOUNTS = {"_nrt": False} if hasattr(DefaultOptions, "_nrt") else {}


def cache_dir(*files: str) -> str:
    """Where numba caches compiled kernels: a folder named by a hash of the given source files.
    Numba itself only watches the file of each jitted function, so a changed equation in a file
    it calls would otherwise run stale machine code."""
    h = hashlib.sha256()
    for path in files:
        h.update(Path(path).read_bytes())
    root = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "lcgym" / "numba"
    return str(root / h.hexdigest()[:16])


class Kernels:
    """The decorator of one module's kernels: ``numba.njit(cache=True, **options)``, the machine code
    cached in ``cache_dir(*sources)``, a folder named by the sources' hash (the module's own file and
    those of the equations it compiles), so that an edited equation never runs from a stale cache.

    ``njit = Kernels(__file__, dynamics.__file__)``, then ``@njit``, ``@njit(fastmath=FASTMATH)`` or
    ``compiled = njit(function)``. numba reads its cache folder when a function is decorated: it is
    set for that moment only, and left as it was for any other code."""

    def __init__(self, *sources: str):
        self.sources = sources
        self.folder = cache_dir(*sources)

    def __call__(self, function: Callable | None = None, **options) -> Callable:
        import numba

        def compile_(f: Callable) -> Callable:
            before = numba.config.CACHE_DIR
            numba.config.CACHE_DIR = self.folder
            try:
                return numba.njit(cache=True, **options)(f)
            finally:
                numba.config.CACHE_DIR = before

        return compile_ if function is None else compile_(function)


def in_row_blocks(kernel, head: tuple, rows: tuple, min_rows: int = 100_000) -> None:
    """``kernel(*head, *rows)`` for a kernel that treats each row of the arrays ``rows`` (the output
    among them, written in place) on its own: on large arrays, in blocks of rows on
    ``numba.get_num_threads()`` threads (the kernel must be compiled ``nogil``). Each row runs the
    same machine code as in one call, so the results are the same bit for bit; the benchmark's
    workers, which set numba to one thread, make one call."""
    import numba

    n_rows = len(rows[0])
    blocks = min(numba.get_num_threads(), n_rows // min_rows)
    if blocks <= 1:
        kernel(*head, *rows)
        return
    edges = np.linspace(0, n_rows, blocks + 1).astype(int)
    with ThreadPoolExecutor(max_workers=blocks) as pool:
        done = [pool.submit(kernel, *head, *(a[s:e] for a in rows)) for s, e in zip(edges[:-1], edges[1:], strict=True)]
        for f in done:
            f.result()
