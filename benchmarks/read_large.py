"""Memory and time of reading a large measurement file: streamed ``read_trials`` against pandas.

Writes one FlexArm-shaped CSV (t, 6 axes x ref/pos/u/ff, 3 accelerometer columns: 28 columns)
of ``--rows`` samples, then reads it in fresh processes, each reporting its peak resident
memory (``VmHWM`` of ``/proc/self/status``, Linux) and time:

- ``baseline``: import lcgym, read nothing (the interpreter, numpy, pandas, pyarrow);
- ``stream``: ``lcgym.data.read_trials`` (chunks of ``CHUNK_ROWS`` rows);
- ``one chunk``: ``read_trials`` with ``CHUNK_ROWS`` larger than the file: the whole file as one
  pandas table, as read_trials read every file before it streamed.

Each peak minus the baseline is the reading's own memory; the ratio to the trial's arrays'
size (float64) says how much the reader needs beyond its result.

Run:  .venv/bin/python benchmarks/read_large.py [--rows 2000000]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

AXES = ("j1", "j2", "j3", "j4", "j5", "j6")

CHILD = r"""
import json, sys, time
import lcgym.data
from lcgym.systems.flexarm import FLEXARM
mode, path = sys.argv[1], sys.argv[2]
t0 = time.perf_counter()
if mode == "stream":
    trials = lcgym.data.read_trials(path, axes=FLEXARM)
    n = trials[0].n_samples
elif mode == "one chunk":
    lcgym.data.CHUNK_ROWS = 10**12
    trials = lcgym.data.read_trials(path, axes=FLEXARM)
    n = trials[0].n_samples
else:
    n = 0
seconds = time.perf_counter() - t0
# VmHWM: this process image's peak (ru_maxrss would carry the forking parent's over exec)
with open("/proc/self/status") as f:
    peak_kib = next(int(line.split()[1]) for line in f if line.startswith("VmHWM"))
print(json.dumps({"rows": n, "seconds": seconds, "peak_mib": peak_kib / 1024}))
"""


def write_file(path: Path, rows: int) -> None:
    """A FlexArm-shaped CSV, written in blocks so that the writer itself stays small."""
    rng = np.random.default_rng(0)
    block = 200_000
    with open(path, "w") as f:
        for start in range(0, rows, block):
            n = min(block, rows - start)
            cols = {"t": (start + np.arange(n)) * 1e-3}
            for p in ("ref", "pos", "u", "ff"):
                for ax in AXES:
                    cols[f"{p}_{ax}"] = rng.normal(scale=0.5, size=n)
            for a in ("acc_x", "acc_y", "acc_z"):
                cols[a] = rng.normal(size=n)
            pd.DataFrame(cols).to_csv(f, index=False, header=start == 0, float_format="%.10g")


def measure(mode: str, path: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, mode, str(path)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=2_000_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "large.csv"
        t0 = time.perf_counter()
        write_file(path, args.rows)
        size_mib = path.stat().st_size / 2**20
        print(f"file: {args.rows:,} rows x 28 columns, {size_mib:.0f} MiB (written in {time.perf_counter() - t0:.0f} s)")
        result_mib = args.rows * 28 * 8 / 2**20
        print(f"the trial's arrays (float64): {result_mib:.0f} MiB")
        base = measure("baseline", path)
        for mode in ("stream", "one chunk"):
            r = measure(mode, path)
            own = r["peak_mib"] - base["peak_mib"]
            print(f"{mode:9s} peak {r['peak_mib']:6.0f} MiB, own {own:6.0f} MiB = {own / result_mib:4.2f} x the arrays, "
                  f"{r['seconds']:5.1f} s ({r['rows']:,} rows)")


if __name__ == "__main__":
    main()
