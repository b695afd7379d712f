"""Readers of public benchmark data sets into lcgym's measurement format (``data.Trial``).

``emps(path)``: the Electro-Mechanical Positioning System benchmark (Janot, Gautier and Brunot
2019; files from the nonlinear system identification benchmarks' site,
https://www.nonlinearbenchmark.org, "EMPS"): a ball-screw-driven prismatic axis under a PD
position loop, sampled at 1 kHz. Its official files (``DATA_EMPS.mat``, ``DATA_EMPS_PULSES.mat``)
hold column vectors ``t`` [s], ``qm`` (motor position measured by the encoder, m), ``qg`` (the
reference position, m), ``vir`` (the amplifier's input, V) and the scalar ``gtau`` (the drive
gain, N/V): the force the motor applies is u = gtau * vir [N]. The machine it belongs to is
``lcgym.systems.examples.emps.EMPS`` (``--system emps``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .data import UNIFORM_TOLERANCE, MeasurementFileError, Trial

EMPS_AXIS = "x"  # the carriage's one prismatic axis
EMPS_VECTORS = ("t", "qm", "qg", "vir")
EMPS_MIN_SAMPLES = 100


def emps(path: str | Path) -> Trial:
    """One EMPS experiment as a Trial on axis ``x``: ``ref`` = qg, ``pos`` = qm [m], ``u`` = gtau *
    vir [N], time from 0 on the file's uniform grid (module docstring). A file that is not a
    MATLAB file, lacks a variable, or has vectors of different lengths, non-finite values or a
    non-uniform time raises ``MeasurementFileError`` naming the file, the variable and the sample."""
    import scipy.io

    path = Path(path)
    if not path.is_file():
        raise MeasurementFileError(f"{path}: no such file")
    try:
        data = scipy.io.loadmat(path)
    except Exception as exc:  # scipy raises ValueError, TypeError or its own MatReadError on a foreign file
        raise MeasurementFileError(f"{path}: not a MATLAB .mat file the EMPS reader can read ({exc})") from None
    missing = [k for k in (*EMPS_VECTORS, "gtau") if k not in data]
    if missing:
        found = sorted(k for k in data if not k.startswith("__"))
        raise MeasurementFileError(f"{path}: an EMPS file holds t, qm, qg, vir and gtau; missing {', '.join(missing)} "
                                   f"(the file has {', '.join(found) or 'no variables'})")
    vectors = {}
    for name in EMPS_VECTORS:
        v = np.asarray(data[name])
        if v.ndim > 2 or (v.ndim == 2 and min(v.shape) != 1) or not np.issubdtype(v.dtype, np.number):
            raise MeasurementFileError(f"{path}: variable {name!r} must be a numeric vector, got shape {v.shape} "
                                       f"of {v.dtype}")
        vectors[name] = v.astype(float).ravel()
    n = vectors["t"].size
    for name, v in vectors.items():
        if v.size != n:
            raise MeasurementFileError(f"{path}: variable {name!r} has {v.size} samples, 't' has {n}")
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise MeasurementFileError(f"{path}: variable {name!r}: value {v[bad[0]]} at sample {bad[0] + 1} (1 = first)")
    gtau = np.asarray(data["gtau"], dtype=float).ravel() if np.issubdtype(np.asarray(data["gtau"]).dtype, np.number) \
        else np.array([])
    if gtau.size != 1 or not np.isfinite(gtau[0]) or gtau[0] <= 0:
        raise MeasurementFileError(f"{path}: variable 'gtau' must be one positive number (N/V), got {data['gtau']!r}")
    if n < EMPS_MIN_SAMPLES:
        raise MeasurementFileError(f"{path}: {n} samples; the reader needs at least {EMPS_MIN_SAMPLES}")
    t = vectors["t"]
    dt = np.diff(t)
    step = (t[-1] - t[0]) / (n - 1)
    off = np.flatnonzero(~(np.abs(dt - step) <= UNIFORM_TOLERANCE * step))
    if not step > 0 or off.size:
        k = int(off[0]) if off.size else 0
        raise MeasurementFileError(f"{path}: variable 't' must rise by a uniform step ({step:.6g} s on average); "
                                   f"from sample {k + 1} to {k + 2} it changes by {dt[k]:.6g} s")
    column = lambda v: v[:, None]  # noqa: E731 - (T,) -> (T, 1), one axis
    return Trial(t=np.arange(n) * step, ref=column(vectors["qg"]), pos=column(vectors["qm"]),
                 u=column(float(gtau[0]) * vectors["vir"]), axes=(EMPS_AXIS,),
                 meta={"system": "emps", "source": f"EMPS benchmark file {path.name}", "gtau": float(gtau[0])})


__all__ = ["emps"]
