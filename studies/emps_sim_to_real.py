"""Sim-to-real check of EMPS-v0: the simulated machine (``lcgym.systems.emps_sim``, the published
parameters and controller) run on the references of the real EMPS runs, its force and tracking
error beside the measured ones.

    .venv/bin/python studies/emps_sim_to_real.py --data DIR [--out docs/img/emps_sim_to_real.png] [--variants]

DIR holds the benchmark's ``DATA_EMPS.mat`` and ``DATA_EMPS_PULSES.mat`` (https://www.nonlinearbenchmark.org,
"EMPS"; lcgym ships none of it). Per run it prints:

* force: RMS of (simulated - measured) / RMS of the measured force, the measured force being
  g_tau vir, the controller's output (``lcgym.datasets.emps``);
* tracking error e = q_r - q_m: RMS simulated / RMS measured, and RMS of (simulated - measured) /
  RMS measured.

The pulses run's ``pulses_N`` are "directly applied" (description Sec. 2.2, which gives them in
N). Read as newtons on the carriage (at most 5 N), they cannot make the measured force's spikes of
200-300 N; read as volts added to the amplifier's input, so that they act as g_tau pulses_N and the
logged vir includes them, the simulated and measured forces agree. The study simulates both
readings, reports both ("pulses as N": the simulated controller's force against the measured one;
"pulses as V": the simulated total input) and plots the second. A plot of both runs' force and
tracking error, simulated over measured, goes to ``--out``.

``--variants``: the same check on the main run with the plant's friction replaced by what a
simpler model has (the question the diagnosis asks, asked of our own machine): the description's
symmetric IDIM-LS friction with its offset (eq. 1: Fv = 203.5034 N s/m, Fc = 20.3935 N, offset =
-3.1648 N), and the nominal model's viscous friction alone (Fv = 203.5034 N s/m).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

RUNS = ("DATA_EMPS.mat", "DATA_EMPS_PULSES.mat")
EPS = 0.0104  # m/s, EMPS-v0's smoothing of the friction's sign


def variants(plant) -> dict:
    """EMPS-v0's plant with simpler friction (module docstring, ``--variants``)."""
    from lcgym.physics import effects as fx
    from lcgym.systems.urdf_plant import URDFPlant

    kinds = {"symmetric friction and offset (description eq. 1)":
             (fx.ViscousFriction("x", d=203.5034), fx.CoulombFriction("x", Fc=20.3935, eps=EPS), fx.Offset("x", c=-3.1648)),
             "viscous friction alone (the nominal model)": (fx.ViscousFriction("x", d=203.5034),)}
    return {name: URDFPlant(plant.system, effects=effects, gains=plant.gains, fs=plant.fs, u_max=plant.u_max,
                            encoder_resolution=plant.encoder_resolution) for name, effects in kinds.items()}


def pulses_of(path: Path, n: int) -> np.ndarray:
    """(n, 1) the run's ``pulses_N`` as logged (zeros where it has none)."""
    import scipy.io

    data = scipy.io.loadmat(path)
    if "pulses_N" not in data:
        return np.zeros((n, 1))
    p = np.asarray(data["pulses_N"], dtype=float).ravel()
    if p.size != n or not np.all(np.isfinite(p)):
        raise ValueError(f"{path}: pulses_N has {p.size} samples (finite: {np.isfinite(p).all()}), the run {n}")
    return p[:, None]


def compare(path: Path, plant, pulses_as: str = "V") -> dict:
    """Simulate the run of ``path`` on ``plant``; the figures of the module docstring and the signals.
    ``pulses_as``: "V" (g_tau pulses_N added to the input, the logged force includes them) or "N"
    (pulses_N added as force, the logged force is the controller's alone)."""
    from lcgym.datasets import emps

    real = emps(path)
    logged = pulses_of(path, real.ref.shape[0])
    pulses = logged * real.meta["gtau"] if pulses_as == "V" else logged
    sim = plant.run(real.ref, pulses)
    force_sim = sim.u if pulses_as == "V" else sim.u - pulses
    e_real, e_sim = real.error[:, 0], sim.error[:, 0]
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    return {
        "run": path.name, "pulses_as": pulses_as if np.any(logged) else "none", "samples": int(real.ref.shape[0]),
        "force_rms_measured_N": round(rms(real.u), 3), "force_rms_simulated_N": round(rms(force_sim), 3),
        "force_rms_difference_relative": round(rms(force_sim[:, 0] - real.u[:, 0]) / rms(real.u), 4),
        "error_rms_measured_mm": round(1e3 * rms(e_real), 5), "error_rms_simulated_mm": round(1e3 * rms(e_sim), 5),
        "error_rms_ratio": round(rms(e_sim) / rms(e_real), 4),
        "error_rms_difference_relative": round(rms(e_sim - e_real) / rms(e_real), 4),
        "_signals": (real.t, real.u[:, 0], force_sim[:, 0], e_real, e_sim),
    }


def plot(results: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(2, len(results), figsize=(6.5 * len(results), 5.5), squeeze=False, sharex="col")
    for col, r in enumerate(results):
        t, f_real, f_sim, e_real, e_sim = r["_signals"]
        axs[0, col].plot(t, f_real, lw=0.6, label="measured")
        axs[0, col].plot(t, f_sim, lw=0.6, label="EMPS-v0")
        axs[0, col].set_title(f"{r['run']}: force, RMS difference {100 * r['force_rms_difference_relative']:.1f} %",
                              fontsize=9)
        axs[0, col].set_ylabel("force [N]")
        axs[1, col].plot(t, 1e3 * e_real, lw=0.6, label="measured")
        axs[1, col].plot(t, 1e3 * e_sim, lw=0.6, label="EMPS-v0")
        axs[1, col].set_title(f"tracking error, RMS simulated / measured {r['error_rms_ratio']:.3f}", fontsize=9)
        axs[1, col].set_ylabel("q_r - q_m [mm]")
        axs[1, col].set_xlabel("time [s]")
        axs[0, col].legend(fontsize=7)
    fig.tight_layout()
    from lcgym.data import atomic_write

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", required=True, help="folder with DATA_EMPS.mat and DATA_EMPS_PULSES.mat")
    parser.add_argument("--out", default="docs/img/emps_sim_to_real.png")
    parser.add_argument("--variants", action="store_true", help="also simpler friction models (module docstring)")
    args = parser.parse_args()
    from lcgym import systems

    folder = Path(args.data)
    missing = [name for name in RUNS if not (folder / name).is_file()]
    if missing:
        raise SystemExit(f"{folder}: missing {', '.join(missing)} (the EMPS benchmark's files)")
    plant = systems.resolve("emps_sim").bench().plant
    results = [compare(folder / name, plant) for name in RUNS]
    for r in [*results, compare(folder / RUNS[1], plant, pulses_as="N")]:
        print(json.dumps({k: v for k, v in r.items() if not k.startswith("_")}))
    if args.variants:
        for name, other in variants(plant).items():
            r = compare(folder / RUNS[0], other)
            print(json.dumps({"plant": name, **{k: v for k, v in r.items() if not k.startswith("_")}}))
    plot(results, Path(args.out))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
