"""Where the model fails: the residual broken down by operating region.

Regions are defined on the reduced rows (after the model's low-pass and decimation) from the
kinematics the model was fitted with, per axis:

- motion: standstill (|qd| below 2 % of the axis's top speed), velocity reversal or start
  (within ``window`` s of a change of the velocity's sign or of a start from standstill),
  moving forward / backward, slow (below 25 % of top speed) and fast (above 60 %);
- acceleration phases: accelerating (|qdd| above 20 % of its top, qdd qd > 0) and decelerating;
- position: quartiles of each moving axis's position (a range of roll angles can matter for the
  propeller);
- time: quarters of the recording (slow drifts, warm-up).

For each region: its share of the samples, the residual RMS inside it, that RMS over the axis's
overall RMS (``ratio``: above 1, the model fails worse there than on average) and the region's
share of the axis's residual energy. Regions holding less than ``min_share`` of the samples are
not ranked; the rest are sorted by ``ratio``, worst first.
"""

from __future__ import annotations

import math

import numpy as np

from .rows import RegionRow


def region_masks(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, trial: np.ndarray, fs_rows: float,
                 axes: tuple, window: float = 0.3) -> dict[str, list[tuple[str, np.ndarray]]]:
    """Boolean masks (R,) per axis: {axis: [(description, mask), ...]}. q, qd, qdd are (R, A)
    at the reduced rows, ``trial`` (R,) the trial of each row, ``fs_rows`` their rate [Hz];
    ``axes`` the machine's ``systems.Axis`` (names, units of the descriptions: deg or mm).
    Axes that stand still (range below their ``min_travel``) get no regions and split no others."""
    out = {}
    n = q.shape[0]
    quarter = np.minimum((np.arange(n) * 4) // max(n, 1), 3)
    moving = [i for i in range(len(axes)) if np.ptp(q[:, i]) >= axes[i].min_travel]
    for i in moving:
        ax = axes[i].name
        f, unit = axes[i].display
        v, a = qd[:, i], qdd[:, i]
        vmax = max(float(np.abs(v).max()), 1e-12)
        amax = max(float(np.abs(a).max()), 1e-12)
        still = np.abs(v) < 0.02 * vmax
        sign = np.where(still, 0, np.sign(v))
        change = np.zeros(n, dtype=bool)
        change[1:] = (sign[1:] != sign[:-1]) & (sign[1:] != 0) & (trial[1:] == trial[:-1])
        near = np.convolve(change.astype(float), np.ones(2 * int(window * fs_rows) + 1), mode="same") > 0
        regions = [
            ("standstill", still),
            (f"velocity reversal or start (within {window:g} s)", near),
            ("moving forward", v > 0.02 * vmax),
            ("moving backward", v < -0.02 * vmax),
            (f"slow (|velocity| < {0.25 * vmax * f:.1f} {unit}/s)", ~still & (np.abs(v) < 0.25 * vmax)),
            (f"fast (|velocity| > {0.6 * vmax * f:.1f} {unit}/s)", np.abs(v) > 0.6 * vmax),
            ("accelerating", (np.abs(a) > 0.2 * amax) & (a * v > 0)),
            ("decelerating", (np.abs(a) > 0.2 * amax) & (a * v < 0)),
        ]
        for j in moving:
            other, (fj, uj) = axes[j].name, axes[j].display
            what = "angle" if axes[j].revolute else "position"
            edges = np.quantile(q[:, j], [0, 0.25, 0.5, 0.75, 1.0])
            for k in range(4):
                lo, hi = edges[k], edges[k + 1]
                m = (q[:, j] >= lo) & ((q[:, j] < hi) if k < 3 else (q[:, j] <= hi))
                regions.append((f"{other} {what} in [{lo * fj:.1f}, {hi * fj:.1f}] {uj}", m))
        regions += [(f"time: quarter {k + 1} of the recording", quarter == k) for k in range(4)]
        out[ax] = regions
    return out


def region_table(residual: np.ndarray, masks: dict, axes: tuple[str, ...], used: np.ndarray | None = None,
                 min_share: float = 0.02) -> list[RegionRow]:
    """A row (``RegionRow``: axis, where, RMS, ratio, samples, energy) for every region of every axis, worst ratio
    first, over each axis's ``used`` rows (R, A) (default all)."""
    rows = []
    for i, ax in enumerate(axes):
        keep = np.ones(residual.shape[0], dtype=bool) if used is None else used[:, i]
        r = residual[keep, i]
        if r.size == 0:
            continue
        total = float((r * r).sum()) or 1.0
        overall = math.sqrt(total / r.size)
        for where, m in masks.get(ax, ()):
            m = m[keep]
            share = float(m.mean())
            if share < min_share:
                continue
            rms = float(np.sqrt(np.mean(r[m] ** 2)))
            rows.append(RegionRow(axis=ax, where=where, RMS=rms, ratio=rms / overall, samples=share,
                                  energy=float((r[m] ** 2).sum() / total)))
    return sorted(rows, key=lambda x: -x.ratio)
