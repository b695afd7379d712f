"""The benchmark runner: systems x methods x seeds, one independent cell each.

A cell (system, method, seed):

1. runs the system's plant with feedback only on the seeded training references (the shared
   training data, counted in every method's ``plant_trials``; computed once per process for all
   methods of a system and seed);
2. builds the method's controller, handing it the cell's machine (``protocol.build_method``), and
   calls ``fit(training trials)``; methods that learn on the plant (``uses_plant``) also get
   ``learn(plant, reference)`` before each evaluation reference (``protocol.apply``);
3. applies its feedforward (and, on the FlexArm, its reference offset) on the training and the
   validation references and computes MA, RMS and Inf of what the system scores
   (``System.bench``, ``systems/<machine>/bench.py``: tracking error [deg] and input residual u - f per axis; on the arm also the
   TCP position error [mm]).

Cells run in parallel through joblib (``jobs``; workers use one numba and one torch thread each),
or on an existing Dask cluster through joblib's dask backend (``dask="tcp://host:port"``). Rows
are appended to the results CSV as each cell finishes, so an interrupted run keeps every finished
cell, and ``resume`` skips cells already stored under the same configuration hash. A controller
that raises, returns a bad feedforward or runs past the per-cell time limit (``timeout``) is
recorded as a failed cell with its error.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import os
import signal
import sysconfig
import threading
import traceback
import uuid
from collections.abc import Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import asdict, dataclass, field, replace
from datetime import UTC, datetime
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from .. import systems
from ..data import atomic_write
from ..methods import CONTROLLERS, load_method, protocol
from ..methods.bases import runs_on
from ..methods.protocol import build_method, display_name, evaluate, method_base, split_spec
from ..provenance import __version__, git_commit, source_hash
from ..systems.runs import remembered_runs
from .shares import row_shares
from .store import append_rows, completed_cells

EVALUATED_SETS = ("train", "validation")
QUICK_BUDGET = 0.5
"""``BenchConfig.quick``'s share of the methods' full learning budgets."""
CELL_REGRESSORS = 3
"""Regressors a cell keeps per reference (``_regressors_kept``): of its reference, measured and shifted kinematics."""


@dataclass(frozen=True)
class BenchConfig:
    """What a benchmark runs: systems, method ids (or module:Class), seeds, and the budgets.

    systems: benchmark names (``systems.resolve``: "ix-v1", "two_link", a machine file, a
    URDF, ``module:attr``); methods: the default runs every registered method on the machines it
    runs on (``basic``: the FlexArm only). n_train / n_validation: references per set; duration:
    seconds of moves per reference (an arm reference is one TCP line out and back; ``FlexArmBench``);
    budget: the fraction of their full learning budget the methods spend (a method's constructor
    keyword ``budget``, ``protocol.build_method``: the PGNN's iterations, ILC's trials).
    """

    systems: tuple[str, ...] = field(default_factory=systems.newest_benchmarks)
    methods: tuple[str, ...] = field(default_factory=lambda: tuple(CONTROLLERS))
    seeds: tuple[int, ...] = (0, 1, 2)
    n_train: int = 8
    n_validation: int = 4
    duration: float = 40.0
    budget: float = 1.0

    def __post_init__(self):
        # versioned names: "ix" is the newest version ("ix-v1"); an unknown name fails with the list
        resolved = [systems.resolve(s) for s in self.systems]
        object.__setattr__(self, "systems", tuple(dict.fromkeys(m.name for m in resolved)))
        machines = {m.machine for m in resolved}
        every = tuple(self.methods) == tuple(CONTROLLERS)  # the default: each method where it runs (cells)
        # "ilc@physical" is "ilc" (the default base): one name per cell, so that --resume finds it
        object.__setattr__(self, "methods", tuple(dict.fromkeys(display_name(*split_spec(m)) for m in self.methods)))
        for m in self.methods:
            where = _runs_on(m)  # fails early with a clear message
            if where is not None and not set(where) & machines and not every:
                raise ValueError(f"method {m!r} runs on {', '.join(where)} only, not on {', '.join(self.systems)}")
        if any(s < 0 for s in self.seeds):
            raise ValueError(f"seeds must be >= 0, got {list(self.seeds)}")
        if not self.systems or not self.methods or not self.seeds:
            raise ValueError("a benchmark needs at least one system, method and seed")
        if self.n_train < 1 or self.n_validation < 1 or not self.duration > 0:
            raise ValueError("n_train, n_validation must be >= 1 and duration > 0")
        if not 0 < self.budget <= 1:
            raise ValueError(f"budget must be a fraction in (0, 1] of the methods' full learning budget, got {self.budget}")

    @classmethod
    def quick(cls, **overrides) -> BenchConfig:
        """A smoke run of every cell: one seed, two short references per set, and the learning methods
        on ``QUICK_BUDGET`` of their full budget."""
        return replace(cls(seeds=(0,), n_train=2, n_validation=2, duration=20.0, budget=QUICK_BUDGET), **overrides)

    def config_hash(self) -> str:
        """Hash of the budgets, the systems and lcgym's own source code.

        Cells of another configuration, or computed by other lcgym code, are neither resumed nor
        ranked together. A machine file or URDF among the systems enters by its content
        (``machine_file_hash``): an edited one is another configuration. Methods and seeds are left
        out (they name the cells); a changed user controller is not detected: start a new CSV after
        changing one.
        """
        payload = {k: v for k, v in asdict(self).items() if k not in ("methods", "seeds")}
        payload["lcgym"] = __version__
        payload["source"] = source_hash()
        payload["machine_files"] = {s: machine_file_hash(s) for s in self.systems if Path(s).is_file()}
        return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:12]

    def cells(self) -> list[tuple[str, str, int]]:
        """(system, method, seed) of every cell; a method with ``systems`` only on those."""
        runs_on = {m: _runs_on(m) for m in self.methods}
        machine = {s: systems.resolve(s).machine for s in self.systems}
        return [(s, m, k) for s in self.systems for m in self.methods for k in self.seeds
                if runs_on[m] is None or machine[s] in runs_on[m]]


def _runs_on(method: str) -> tuple[str, ...] | None:
    """The machines ("flexarm") a method id, with its base, runs on (None: all)."""
    return runs_on(load_method(method, CONTROLLERS).systems, split_spec(method)[1])


def _worker_setup() -> None:
    """A parallel cell's worker: one numba and one torch thread (two threads each slow 10-100x when
    the other worker is busy), loky's leak guard widened (``_widen_leak_guard``), and tqdm's lock a
    thread lock (its default is a process lock, a named semaphore that a worker killed by a stopped
    bench leaves registered: Python then warns of a leaked semaphore)."""
    import numba
    import torch
    from tqdm import std

    numba.set_num_threads(1)
    torch.set_num_threads(1)
    _widen_leak_guard()
    std.tqdm.set_lock(threading.RLock())


LOKY_MEMORY_GROWTH = int(2e9)
"""Bytes a joblib (loky) worker may grow past its size after its first cell before loky stops it as
leaking and starts a new one (loky's own bound: 300 MB)."""


def _widen_leak_guard() -> None:
    """Raise loky's leak bound in this worker to ``LOKY_MEMORY_GROWTH``. What a worker keeps is
    meant and bounded: a cell's regressors (``_regressors_kept``: about 240 MB in the FlexArm's
    quick cell, released when it ends, though the process may keep the pages) and the runs it
    remembers (``systems.runs``, at most ``SIZE``). Under loky's 300 MB a quick bench lost two
    workers, each costing a core the new worker's start (about 3 s) and the runs the old one
    remembered. The bound is loky's module constant (``psutil`` installed: else loky checks nothing),
    read by the worker after each task; a joblib without it is left as it is."""
    try:
        from joblib.externals.loky import process_executor
    except ImportError:
        return
    if isinstance(getattr(process_executor, "_MAX_MEMORY_LEAK_SIZE", None), int):
        process_executor._MAX_MEMORY_LEAK_SIZE = max(process_executor._MAX_MEMORY_LEAK_SIZE, LOKY_MEMORY_GROWTH)


@lru_cache(maxsize=16)  # every machine and seed of a full run: its cells come in the order of costliest_first
def _training_trials(machine: systems.BenchMachine, seed: int, config: BenchConfig) -> list:
    """The feedback-only runs of a cell's training references: the same for every method of a
    (machine, seed, budget), so computed once per process (the plants are deterministic)."""
    bench = machine.bench()
    return bench.run(bench.references("train", seed, config.n_train, config.duration))


def _rms_per_axis(signals: Sequence[np.ndarray]) -> np.ndarray:
    x = np.concatenate([np.asarray(s, dtype=float) for s in signals])
    return np.sqrt(np.mean(x * x, axis=0))


class CellTimeout(TimeoutError):
    """A cell ran past the benchmark's per-cell time limit."""


@contextmanager
def _time_limit(seconds: float | None, where: list[str]):
    """Raise ``CellTimeout`` in this thread after ``seconds`` of wall time, naming ``where[0]``
    (the stage the cell is in). A signal timer: POSIX and the main thread only (the benchmark's
    own and joblib's worker processes); elsewhere (Windows, Dask's worker threads) no limit."""
    if seconds is None or not hasattr(signal, "setitimer") or threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum, frame):
        raise CellTimeout(f"the cell ran past its time limit of {seconds:g} s, in {where[0]}")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_cell(system: str, method: str, seed: int, config: BenchConfig, single_thread: bool = False,
             timeout: float | None = None) -> tuple[list[dict], pd.DataFrame | None]:
    """Run one cell: its result rows (without run id and provenance) and the trace of its first
    validation reference (``Bench.trace``; None for a failed cell). ``timeout`` [s]: the
    method's part of the cell (fit, learn, feedforward and the evaluation runs) may take this
    long; past it the cell is recorded as failed with ``CellTimeout`` and the stage it was in."""
    if single_thread:
        _worker_setup()
    key = {"system": system, "method": method, "base": method_base(method, CONTROLLERS), "seed": seed,
           "config_hash": config.config_hash()}
    machine = systems.resolve(system)
    bench = machine.bench()
    refs = {name: bench.references(name, seed, n, config.duration)
            for name, n in (("train", config.n_train), ("validation", config.n_validation))}
    train_trials = copy.deepcopy(_training_trials(machine, seed, config))  # a copy: a method may alter its trials
    stage = ["loading the method"]
    try:
        with _time_limit(timeout, stage), _regressors_kept(machine.system, config), remembered_runs():
            controller = build_method(method, machine.system, CONTROLLERS, config.budget)
            learn_seconds, evaluated = evaluate(controller, bench, train_trials, {s: refs[s] for s in EVALUATED_SETS},
                                                stage=stage)
            rows = []
            for set_name, result in evaluated.items():
                nn = result.signals.nn_contributions
                nn_rms = dict(zip(bench.axes, _rms_per_axis(nn), strict=True)) if nn else {}
                for row in _scored_rows(bench, result.tables):
                    row.pop("label")
                    rows.append({**key, "period": "all", **row, "reference_set": set_name,
                                 "nn_rms": nn_rms.get(row["axis"], np.nan)})
            cost = controller.cost_
            for row in rows:
                row.update(plant_trials=config.n_train + cost.plant_trials, env_steps=cost.env_steps,
                           fit_seconds=round(learn_seconds + cost.cached_seconds, 3), status="ok", error="",
                           note=controller.note_)
            return rows, bench.trace(evaluated["validation"].trials[0])
    except Exception as exc:  # a method's failure is a result, not a crash of the benchmark
        return [{**key, "status": "failed", "error": _failure(exc, stage[0])[:500]}], None


def _scored_rows(bench, tables: Sequence[pd.DataFrame]) -> list[dict]:
    """The rows of a bench's norm tables in the order of the signals it declares (``bench.signals``),
    each with its signal's label; a signal it does not declare is an error of the bench."""
    labels = {s.name: s.label for s in bench.signals}
    order = {name: i for i, name in enumerate(labels)}
    rows = [row for table in tables for row in table.to_dict("records")]
    undeclared = sorted({row["signal"] for row in rows} - set(labels))
    if undeclared:
        raise ValueError(f"bench {bench.name} scores {', '.join(undeclared)} without declaring it in its signals")
    rows.sort(key=lambda row: order[row["signal"]])  # stable: each signal's rows keep their order
    return [{**row, "signal_label": labels[row["signal"]]} for row in rows]


def _regressors_kept(machine, config: BenchConfig):
    """Keep the machine's regressors of the cell's kinematics while it runs (``System.caching``):
    a learner evaluates its base on each reference again and again (its fit, its safeguard's runs,
    its feedforward), the same values each time. Per reference about 20 MB on the FlexArm."""
    if machine.caching is None:
        return nullcontext()
    return machine.caching(size=CELL_REGRESSORS * (config.n_train + config.n_validation))


def _failure(exc: Exception, stage: str) -> str:
    """One line for a failed cell: the exception, the stage of the cell, and the innermost line of
    the method's own code that raised it (file name and line; not a line of numpy or another
    installed package, nor of this runner or the protocol's driver, whose checks say what they
    refused), so that a user's bug is found without a traceback. A time limit names its stage itself."""
    if isinstance(exc, CellTimeout):
        return f"{type(exc).__name__}: {exc}"
    library = (sysconfig.get_paths()["stdlib"], sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"])
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if f.filename not in (__file__, protocol.__file__) and not f.filename.startswith(library)]
    place = f" at {Path(frames[-1].filename).name}:{frames[-1].lineno}" if frames else ""
    return f"{type(exc).__name__} in {stage}{place}: {' '.join(str(exc).split())}"


def costliest_first(cells: Sequence[tuple[str, str, int]]) -> list[tuple[str, str, int]]:
    """The cells in the order parallel workers take them: the methods' ``relative_cost`` from the
    costliest down (a stable sort: a method's cells keep the machines' and seeds' order). Started
    last, a long cell would run on alone while the other workers idle."""
    cost = {m: float(load_method(m, CONTROLLERS).relative_cost) for m in {c[1] for c in cells}}
    return sorted(cells, key=lambda c: -cost[c[1]])


def traces_dir(out: str | Path) -> Path:
    """Folder of the traces of a results CSV: ``<csv>.traces/<config_hash>/<system>_<method>_<seed>.parquet``
    (files written before traces were kept per configuration lie in it without the hash folder)."""
    return Path(f"{out}.traces")


def _file_name_part(text: str) -> str:
    """``text`` as part of a file name: kept where it is a plain name ("ix-v1", "my_arm.toml"); a
    path or ``module:attr`` becomes its last part, made safe, plus a short hash of the whole text,
    so that two machines of the same file name in different folders do not share a trace."""
    if text and all(c.isalnum() or c in "-_." for c in text) and not text.startswith("."):
        return text
    last = text.replace("\\", "/").rstrip("/").rsplit("/", 1)[-1]
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in last).lstrip(".") or "machine"
    return f"{safe}-{hashlib.sha256(text.encode()).hexdigest()[:8]}"


def machine_file_hash(path: str | Path) -> str:
    """SHA-256 of a machine file or URDF as the benchmark runs it: its bytes, and a machine file's
    URDF's (the ``urdf`` key, relative to the file)."""
    import tomllib

    path = Path(path)
    digest = hashlib.sha256(path.read_bytes())
    if path.suffix == ".toml":
        try:
            with path.open("rb") as file:
                urdf = tomllib.load(file).get("urdf")
        except (tomllib.TOMLDecodeError, UnicodeDecodeError):
            urdf = None  # loading the machine refuses it, with the line
        if isinstance(urdf, str) and (path.parent / urdf).is_file():
            digest.update((path.parent / urdf).read_bytes())
    return digest.hexdigest()


def trace_path(out: str | Path, system: str, method: str, seed: int, config_hash: str | None = None) -> Path:
    """Where the trace of a cell is stored: in the results CSV's traces folder, in a folder of its
    configuration (what makes a row unique: configuration, system, method, seed; two runs of other
    budgets into one CSV keep their own traces), whatever the system's or the method's name (a
    machine file's relative path, ``module:Class``) holds. ``config_hash`` None: the path before traces
    were kept per configuration, where older files lie."""
    folder = traces_dir(out) if config_hash is None else traces_dir(out) / _file_name_part(str(config_hash))
    return folder / f"{_file_name_part(system)}_{_file_name_part(method)}_{seed}.parquet"


def stored_trace(out: str | Path, system: str, method: str, seed: int, config_hash: str | None) -> Path | None:
    """The trace file of a stored row: its configuration's, else one written before traces were kept
    per configuration (None: neither exists)."""
    paths = [trace_path(out, system, method, seed, config_hash)] if config_hash else []
    return next((p for p in [*paths, trace_path(out, system, method, seed)] if p.exists()), None)


def usable_cores() -> int:
    """CPU cores this process may run on (its affinity where the OS tells it, else all)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def run_benchmark(config: BenchConfig, out: str | Path, jobs: int | None = 1, dask: str | None = None,
                  resume: bool = False, progress: bool = True, timeout: float | None = None) -> dict:
    """Run every cell (skipping stored ones with ``resume``) and append the rows to ``out``.
    ``jobs``: parallel cells (None: one per usable core, at most one per cell). ``timeout``:
    per-cell time limit [s] of the method's part (``run_cell``; none on Dask).

    Returns {"run_id", "cells_run", "cells_skipped", "cells_failed"}.
    """
    out = Path(out)
    if not out.resolve().parent.is_dir():
        raise ValueError(f"cannot write {out}: folder {out.parent} does not exist")
    if timeout is not None and not timeout > 0:
        raise ValueError(f"timeout must be > 0 s, got {timeout}")
    todo = config.cells()
    skipped = 0
    if resume:
        done = completed_cells(out, config.config_hash())
        skipped = sum(c in done for c in todo)
        todo = [c for c in todo if c not in done]
    if jobs is None:
        jobs = max(1, min(usable_cores(), len(todo)))
    run_id = uuid.uuid4().hex[:12]
    provenance = {"run_id": run_id, "lcgym_version": __version__, "git_commit": git_commit()}
    failed = 0

    def store(result: tuple[list[dict], pd.DataFrame | None]) -> None:
        nonlocal failed
        rows, trace = result
        stamp = datetime.now(UTC).isoformat(timespec="seconds")
        failed += any(r["status"] == "failed" for r in rows)
        if trace is not None:  # the trace first: a stored row always has its trace
            path = trace_path(out, rows[0]["system"], rows[0]["method"], rows[0]["seed"], rows[0]["config_hash"])
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(path, lambda tmp: trace.to_parquet(tmp, index=False))
        append_rows(out, [{**r, **provenance, "timestamp": stamp} for r in rows],
                    derive=lambda table: table.assign(share=row_shares(table)))

    bar = tqdm(total=len(todo), desc="lcgym bench", unit="cell", disable=not progress)
    running: list[tuple] = []  # the cells started and not stored: what a stop names
    finished = 0

    def stored(result) -> None:
        nonlocal finished
        store(result)
        finished += 1
        bar.update()
        rows = result[0]
        if rows and (cell := (rows[0]["system"], rows[0]["method"], rows[0]["seed"])) in running:
            running.remove(cell)  # on Dask, where ``running`` holds every cell not yet stored

    try:
        if dask is None and jobs == 1:
            for cell in todo:
                bar.set_postfix_str("/".join(map(str, cell)))
                running[:] = [cell]
                stored(run_cell(*cell, config, timeout=timeout))
                running.clear()
        elif dask is None:
            _run_in_workers(todo, config, jobs, timeout, stored, running)
        else:
            running[:] = todo  # Dask does not say which have started: the cells not stored are named
            _run_on_dask(todo, config, dask, timeout, stored)
    except KeyboardInterrupt as exc:
        raise BenchStopped(finished, [c for c in todo if c in running], out) from exc
    finally:
        bar.close()
    return {"run_id": run_id, "cells_run": len(todo), "cells_skipped": skipped, "cells_failed": failed}


class BenchStopped(KeyboardInterrupt):
    """``lcgym bench`` was stopped (Ctrl-C, or SIGTERM through ``stop_on_sigterm``): ``finished``
    cells were stored, ``in_flight`` (system, method, seed) were running and are not; their workers
    are gone. ``--resume`` runs them and the rest."""

    def __init__(self, finished: int, in_flight: list[tuple], out: Path):
        self.finished, self.in_flight, self.out = finished, in_flight, out
        names = ", ".join("/".join(map(str, c)) for c in in_flight) or "none"
        super().__init__(f"stopped: {finished} finished cell{'s' * (finished != 1)} stored in {out}; "
                         f"in flight, not stored: {names}; add --resume to run them and the rest")


def _run_in_workers(todo: list[tuple], config: BenchConfig, jobs: int, timeout: float | None, stored, running: list) -> None:
    """Run the cells in ``jobs`` worker processes (loky's, as joblib's), the costliest first; as
    joblib does, twice as many cells as workers are handed out at a time, so that a worker starts its
    next cell while the main process stores the last one. On a stop ``running`` gets the cells the
    workers had started. The workers are this run's own: they end with it, and on any other exit (a
    stop, an error) they are killed, so that none computes on, or holds its memory, after the bench
    has ended."""
    from concurrent.futures import FIRST_COMPLETED, wait

    from joblib.externals.loky import ProcessPoolExecutor

    executor = ProcessPoolExecutor(max_workers=jobs, env=_worker_env(jobs))
    waiting = iter(costliest_first(todo))
    futures = {}

    def start(cell) -> None:
        futures[executor.submit(run_cell, *cell, config, True, timeout)] = cell

    try:
        for cell in itertools.islice(waiting, 2 * jobs):
            start(cell)
        while futures:
            done, _ = wait(futures, return_when=FIRST_COMPLETED)
            for future in done:
                futures.pop(future)
                stored(future.result())
                if (following := next(waiting, None)) is not None:
                    start(following)
    except BaseException:
        running[:] = [cell for future, cell in futures.items() if future.running()]
        executor.shutdown(wait=True, kill_workers=True)
        raise
    executor.shutdown(wait=True)


THREAD_LIMITS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                 "VECLIB_MAXIMUM_THREADS", "NUMBA_NUM_THREADS", "NUMEXPR_NUM_THREADS")


def _worker_env(jobs: int) -> dict[str, str]:
    """The environment joblib gives its process workers, which the benchmark's rows were made with:
    each thread pool (BLAS, OpenMP, numba) limited to the cores over the workers, unless the user's
    environment sets it; TBB told to share its threads between processes. A BLAS of two threads sums
    in another order than one: the RBF expert's rows moved in their 4th digit."""
    from joblib import cpu_count

    threads = str(max(cpu_count() // jobs, 1))
    env = {var: os.environ.get(var, threads) for var in THREAD_LIMITS}
    return env if "ENABLE_IPC" in os.environ else {**env, "ENABLE_IPC": "1"}


def _run_on_dask(todo: list[tuple], config: BenchConfig, address: str, timeout: float | None, stored) -> None:
    """Run the cells on the Dask cluster at ``address`` (joblib's Dask backend)."""
    from joblib import Parallel, delayed, parallel_config

    try:
        from dask.distributed import Client
    except ImportError:
        raise ValueError("--dask needs the 'distributed' package: pip install distributed") from None
    client = Client(address)
    try:
        with parallel_config(backend="dask"):
            tasks = (delayed(run_cell)(*cell, config, True, timeout) for cell in costliest_first(todo))
            for result in Parallel(n_jobs=-1, batch_size=1, return_as="generator_unordered")(tasks):
                stored(result)
    finally:
        client.close()


@contextmanager
def stop_on_sigterm():
    """Within: SIGTERM stops as Ctrl-C does (a ``KeyboardInterrupt`` in the main thread), so that a
    stopped bench stores what finished and kills its workers (``run_benchmark``)."""
    def interrupt(signum, frame):
        raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
