"""``FeedbackGains``: the fixed feedback of a simulated plant, one type for every machine.

A diagonal PID per axis, in the machine's axis order, with a first-order low-pass of corner
``f_lp`` [Hz] on one of two places, ``filtered``:

* ``"output"``: the whole PD output, C(s) = (kp + kd s) / (1 + s / (2 pi f_lp)) (the IX's
  amplifier, ``systems/ix/plant.py``; no integral action there);
* ``"derivative"``: the derivative term only, C = kp + ki / s + kd s / (1 + s / (2 pi f_lp))
  (``URDFPlant``, every machine given by a URDF or a machine file).

What the derivative term differentiates, ``derivative`` (``URDFPlant`` only; the IX's is "error"):

* ``"error"``: kd d e / dt, e = ref - y (it also acts on the reference's velocity);
* ``"measurement"``: -kd d y / dt, y the encoder reading (a velocity loop on the measured
  position: the reference's velocity is not fed through);
* ``"measurement_fir2"``: -kd (y[k] - y[k-2]) / (2 Ts), the measured position averaged over two
  samples, then differenced, without the low-pass: the EMPS's cascaded position / velocity
  controller (Janot, Gautier and Brunot 2019, eq. 6 and Sec. 2.2: nu = kp kv (q_r - q) - kv qd_m).

Each plant implements its own place (and says so if handed the other); the sampled forms are in
their docstrings. A URDF plant's gains for a bandwidth, and their stability check:
``urdf_plant.tuned_gains``, ``urdf_plant.loop_stable``.

Units per axis: kp [input unit per rad or m], kd [input unit s per rad or m], ki [input unit per
(rad s) or (m s)]; u_max [input unit]: the input limit where the gains carry it (the IX's
amplifier; None: the plant's own).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FILTERED = ("output", "derivative")
DERIVATIVES = ("error", "measurement", "measurement_fir2")


@dataclass(frozen=True)
class FeedbackGains:
    """Diagonal PID + first-order low-pass per axis (module docstring): kp, kd and ki (None: no
    integral action) one value per axis; f_lp [Hz] one value or one per axis; filtered: "output" or
    "derivative", given by name (it is a different controller); u_max [input unit] or None;
    derivative: what the derivative term differentiates (module docstring)."""

    kp: tuple[float, ...]
    kd: tuple[float, ...]
    ki: tuple[float, ...] | None = None
    f_lp: float | tuple[float, ...] = 100.0
    u_max: float | None = None
    filtered: str = field(default="", kw_only=True)
    derivative: str = field(default="error", kw_only=True)

    def __post_init__(self):
        if self.filtered not in FILTERED:
            raise ValueError(f"FeedbackGains.filtered must be 'output' (the PD output low-passed) or 'derivative' (the "
                             f"derivative term only), got {self.filtered!r}")
        if self.derivative not in DERIVATIVES:
            raise ValueError(f"FeedbackGains.derivative must be one of {', '.join(DERIVATIVES)}, got {self.derivative!r}")
        n = len(self.kp)
        ki = (0.0,) * n if self.ki is None else self.ki
        f_lp = (self.f_lp,) * n if np.ndim(self.f_lp) == 0 else self.f_lp
        for what, value in (("kp", self.kp), ("kd", self.kd), ("ki", ki), ("f_lp", f_lp)):
            v = np.asarray(value, dtype=float)
            if v.shape != (n,) or not np.all(np.isfinite(v)):
                raise ValueError(f"FeedbackGains.{what} must be {n} finite values (one per axis), got {value!r}")
            object.__setattr__(self, what, tuple(float(x) for x in v))
        if any(f <= 0 for f in self.f_lp):
            raise ValueError(f"FeedbackGains.f_lp must be > 0 Hz, got {self.f_lp}")
        if self.u_max is not None and not self.u_max > 0:
            raise ValueError(f"FeedbackGains.u_max must be > 0 or None, got {self.u_max}")

    @property
    def n_axes(self) -> int:
        return len(self.kp)

    def require(self, filtered: str, plant: str) -> FeedbackGains:
        """These gains, or a ValueError when ``plant`` low-passes elsewhere than they say."""
        if self.filtered != filtered:
            raise ValueError(f"{plant} low-passes the {filtered if filtered == 'output' else 'derivative term'} of its "
                             f"feedback: give FeedbackGains(..., filtered={filtered!r}), got filtered={self.filtered!r}")
        if filtered == "output" and self.derivative != "error":
            raise ValueError(f"{plant} differentiates the tracking error: give derivative='error', got {self.derivative!r}")
        return self


__all__ = ["DERIVATIVES", "FILTERED", "FeedbackGains"]
