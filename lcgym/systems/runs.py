"""Closed-loop runs remembered while a benchmark runs: its methods run one plant on the same references
with the same signals again and again (the physical model's feedforward on each training reference
is run by the ``physical`` cell, by the safeguards of ILC transfer, the RBF expert and the PGNN, by
ILC's first trial, and on the validation references once more for every method that kept nothing).
A plant whose trial is a function of its inputs (``deterministic``: no noise drawn from a stream
that carries on from run to run) returns a copy of the trial it ran before: the same trial, bit for
bit, without running it again. A method still counts every run it asked for (``plant_trials``).

Only inside ``remembered_runs()`` (the benchmark's cells); the last ``SIZE`` runs of the process
are kept (``WORKSPACE``'s slot ``"systems.runs"``), keyed by the plant's configuration (its
``repr``: every field of the plant's dataclass), the reference (name and positions) and the
signals.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import inspect
import threading
from collections import OrderedDict
from contextlib import contextmanager

import numpy as np

from ..physics.workspace import WORKSPACE

SIZE = 64
_active = [0]
_lock = threading.Lock()


def _store() -> OrderedDict:
    """The runs kept, oldest first."""
    return WORKSPACE.slot("systems.runs", OrderedDict)


@contextmanager
def remembered_runs():
    """Plants' ``remembered`` runs are kept and reused while the block runs (nested blocks share them)."""
    _active[0] += 1
    try:
        yield
    finally:
        _active[0] -= 1


def remembered(run):
    """Decorate a plant's ``run(references, *signals)`` (one reference or a list, with one signal
    or a list of them per argument) so that inside ``remembered_runs()`` a deterministic plant
    reruns nothing it ran before."""

    signature = inspect.signature(run)

    @functools.wraps(run)
    def wrapper(self, references, *signals, **named):
        if not _active[0] or not self.deterministic:
            return run(self, references, *signals, **named)
        bound = signature.bind(self, references, *signals, **named)
        bound.apply_defaults()  # a signal left out is its default (None): the same run as one given as None
        signals = tuple(bound.arguments.values())[2:]
        single = not isinstance(references, (list, tuple))
        refs = [references] if single else list(references)
        per_ref = [[s] * len(refs) if single or s is None else list(s) for s in signals]
        if any(len(s) != len(refs) for s in per_ref):
            return run(self, references, *signals)  # the plant's own check says what is wrong
        plant = repr(self)
        keys = [_key(plant, r, [s[i] for s in per_ref]) for i, r in enumerate(refs)]
        found = {}
        store = _store()
        with _lock:  # a bench runs its references in threads
            for i, k in enumerate(keys):
                if k in store:
                    store.move_to_end(k)
                    found[i] = copy.deepcopy(store[k])
        missing = [i for i in range(len(refs)) if i not in found]
        if missing:
            if single:
                ran = [run(self, references, *signals)]
            else:
                ran = run(self, [refs[i] for i in missing],
                          *(None if s is None else [per_ref[j][i] for i in missing] for j, s in enumerate(signals)))
            with _lock:
                for i, trial in zip(missing, ran, strict=True):
                    found[i] = trial
                    store[keys[i]] = copy.deepcopy(trial)  # a copy: the caller may alter its trial
                    while len(store) > SIZE:
                        store.popitem(last=False)
        trials = [found[i] for i in range(len(refs))]
        return trials[0] if single else trials

    return wrapper


def _key(plant: str, reference, signals) -> bytes:
    h = hashlib.blake2b(plant.encode(), digest_size=20)
    name = getattr(reference, "name", None)
    h.update(b"\0" if name is None else name.encode())
    for x in (getattr(reference, "positions", reference), *signals):
        if x is None:
            h.update(b"\1none")
            continue
        a = np.ascontiguousarray(np.asarray(x, dtype=float))
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.digest()
