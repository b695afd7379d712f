"""How robust the diagnosis is to shapes it does not know, to effects that hide each other, and to
logs as real controllers write them.

Part "ix". For each effect of the vocabulary that a plant can carry in another shape than the library's
formula, an IX plant hides that version (a ``TabulatedForce`` curve); for pairs, one effect five
times the RMS of the other (along the references' motion), on one axis or on two. Feedback-only
runs of three training references (70,000 samples) per seed; the diagnosis runs, then the
selected effects are added. Prints, per case, how often the truth's family and axis (or, for a
pair, both effects) were named first (in the first two picks), the selected effects of seed 0,
and the range over the seeds of the truth axis's residual RMS after / before adding the
selected effects; writes the table as Markdown to ``--out`` (the table of docs/diagnosis.md).

Part "logs" (``LOG_CASES``). URDF arms simulated with pinocchio (``URDFPlant``: the Franka Panda
of ``tests/data/panda``, lcgym's ``cobot6`` and ``two_link``) under PD feedback, their runs
made to look like real controllers' logs (``lcgym.logs``): logging dropouts, three runs of
5-6 s, standstill held at both ends, 100 Hz logs with jittered stamps and no reference, an
unsettled start with moves cut off; hidden effects outside the library's formulas (a friction
growing with the square root of speed, a one-sided spring growing quadratically), a Coulomb level
that grows with the gravity load, and none at all. Per case: how often every true effect was named
(family and axis) with nothing else selected, the selected effects of the first seed, the true
axes' residual RMS after / before adding the selected effects, and what the truth allows (the same
runs without the hidden effects: their residual / before). ``tests/test_diagnose_logs.py`` runs
each case (one seed).

Part "runs" (``RUN_CASES``, issue 49): what is named must hold on the next run. A validation run
twice as fast as the runs fitted (``--validate``: the worst joint's residual with the selected
effects over the rigid-body model's), one trajectory run twice (the selection stricter; validated
on another trajectory), and joints driven in proportion (an effect over one's position could
follow the other's: none is tried there), a logger that low-passed the torques at 2 Hz and the
positions at 3 Hz, and a concave friction on a shoulder moving alone (125 Hz, logging gaps).
``tests/test_diagnose_logs.py`` runs each case (one seed).

Run:  .venv/bin/python studies/diagnose_robustness.py [--part ix|logs|runs|all] [--seeds 0,1,2] [--out robustness.md]
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from lcgym import logs, systems
from lcgym.data import Trial, atomic_write
from lcgym.diagnose import diagnose
from lcgym.diagnose.workflow import moving_axes
from lcgym.physics import effects as fx
from lcgym.systems.examples import COBOT6_FRICTION
from lcgym.systems.ix import IX
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import reference_set
from lcgym.systems.urdf_plant import URDFPlant, random_references

DEG = math.pi / 180.0
PANDA = Path(__file__).resolve().parents[1] / "tests" / "data" / "panda" / "panda.urdf"
COBOT = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
COBOT_FRICTION = tuple(f for f, _ in COBOT6_FRICTION)  # N m, Coulomb levels of the cobot's joints
ENCODER = 2 * math.pi / 2**18  # rad per count: 18-bit encoders


def table(axis: str, variable: str, function, lo: float, hi: float) -> fx.TabulatedForce:
    return fx.TabulatedForce.from_function(axis, variable, function, lo, hi, 1001)


def arctan_friction(fwd: float, back: float, width: float = 0.5 * DEG):
    return lambda v: np.where(v > 0, fwd, back) * (2 / np.pi) * np.arctan(v / width)


# name -> (hidden effects, the family and axis expected first, or the keys of a pair)
OTHER_SHAPES = {
    "coulomb_friction: arctan, 0.1 V": ((table("roll", "velocity", arctan_friction(0.1, 0.1), -0.7, 0.7),),
                                        ("friction", "roll")),
    "asymmetric_friction: arctan, 0.20 / 0.15 V": ((table("roll", "velocity", arctan_friction(0.2, 0.15), -0.7, 0.7),),
                                                   ("friction", "roll")),
    "stribeck_friction: exponential hump": ((table("roll", "velocity", lambda v: (
        0.05 + 0.1 * np.exp(-np.abs(v) / (3 * DEG))) * np.tanh(v / (0.2 * DEG)), -0.7, 0.7),), ("friction", "roll")),
    "offset: 0.05 V, drifting 20 % over the range": ((table("roll", "position", lambda q: 0.05 * (1 + 0.2 * q / 1.5),
                                                            -1.6, 1.6),), ("offset", "roll")),
    "offset, the library's: 0.05 V": ((fx.Offset("roll", c=0.05),), ("offset", "roll")),
    "asymmetric_friction, the library's: 0.12 / 0.08 V": ((fx.AsymmetricFriction("roll", Fc_pos=0.12, Fc_neg=0.08,
                                                                                  eps=1e-3),), ("friction", "roll")),
    "cable_spring: quadratic beyond 10 deg": ((table("roll", "position", lambda q: 0.6 * np.maximum(0, q - 10 * DEG) ** 2,
                                                     -1.6, 1.6),), ("spring", "roll")),
    "gear_harmonic: triangle wave, 4 deg": ((table("propeller", "position", lambda q: 0.12 * 2 / np.pi * np.arcsin(
        np.sin(2 * np.pi * q / (4 * DEG))), -np.pi, np.pi),), ("periodic", "propeller")),
    "cable_drape: with a second harmonic": ((table("roll", "position", lambda q: 0.1 * np.sin(q + 0.5)
                                                   + 0.03 * np.sin(2 * q), -1.6, 1.6),), ("gravity", "roll")),
    "cable_drape: only while the roll angle is positive": ((table("roll", "position", lambda q: 0.1 * np.maximum(
        0, np.sin(q)), -1.6, 1.6),), ("gravity", "roll")),
}


def rms_along(effect, refs) -> float:
    """RMS [V] of an effect's torque on its axis along the references' motion."""
    q = np.concatenate([r.positions for r in refs])
    qd = np.concatenate([r.velocities for r in refs])
    e = IX.effect(effect)
    return float(np.sqrt(np.mean(e.torque(q, qd, 0 * qd)[:, e.index] ** 2)))


def scaled(effect, k_name: str, rms: float, refs):
    """``effect`` with its coefficient ``k_name`` set so that its RMS along ``refs`` is ``rms``."""
    unit = effect.__class__(**{**effect.__dict__, k_name: 1.0, "index": None})
    return unit.__class__(**{**unit.__dict__, k_name: rms / rms_along(unit, refs), "index": None})


def pairs(refs) -> dict:
    """Pairs with one effect five times the other's RMS: (hidden, the two keys)."""
    friction = fx.CoulombFriction("roll", Fc=0.05)
    small = rms_along(friction, refs)
    spring = lambda axis, q0: scaled(fx.CableSpring(axis, k=1.0, q0=q0, width=3 * DEG), "k", 5 * small, refs)  # noqa: E731
    return {
        "coulomb_friction@roll behind cable_spring@roll (5x)": ((friction, spring("roll", 20 * DEG)),
                                                                ("cable_spring@roll", "coulomb_friction@roll")),
        "coulomb_friction@roll, cable_spring@propeller (5x)": ((friction, spring("propeller", 10 * DEG)),
                                                               ("cable_spring@propeller", "coulomb_friction@roll")),
        "cable_spring@roll behind coulomb_friction@roll (5x)": (
            (scaled(fx.CoulombFriction("roll", Fc=1.0), "Fc", 5 * small, refs),
             scaled(fx.CableSpring("roll", k=1.0, q0=20 * DEG, width=3 * DEG), "k", small, refs)),
            ("coulomb_friction@roll", "cable_spring@roll")),
        # the propeller's viscous friction takes up most of a small Coulomb level (it turns fast, in one
        # direction for long): 0.15 V, named alone, is the small one there
        "coulomb_friction@propeller behind gear_harmonic@propeller (5x)": (
            (fx.CoulombFriction("propeller", Fc=0.15),
             gear_harmonic(5 * rms_along(fx.CoulombFriction("propeller", Fc=0.15), refs), refs)),
            ("gear_harmonic@propeller", "coulomb_friction@propeller")),
    }


def gear_harmonic(rms: float, refs) -> fx.GearHarmonic:
    """The tests' propeller gear harmonic (two harmonics, speed-dependent) scaled to ``rms`` [V]."""
    shape = lambda a: fx.GearHarmonic.from_amplitudes("propeller", a, 0.7, 0.06 / 0.14 * a, 2.0, velocity_gain=0.5)  # noqa: E731
    return shape(rms / rms_along(shape(1.0), refs))


# ---------------------------------------------------------------------------------------------
# Part "logs": URDF arms, logs as real controllers write them
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LogCase:
    """A simulated log with a known truth: ``make(seed, hidden)`` -> (machine, trials) simulates the
    case's machine with the effects ``hidden`` (the case's ``hidden``, or none for the twin that
    says what the truth allows); ``truth``: the (family, axis) pairs to be named, nothing else."""

    name: str
    hidden: tuple
    truth: tuple[tuple[str, str], ...]
    make: Callable[[int, tuple], tuple[systems.System, list[Trial]]]
    note: str = ""


def _cobot(joints=COBOT) -> systems.System:
    return systems.get("cobot6", joints=joints)


def _run(machine, hidden, seed: int, n: int, duration: float, **plant) -> list[Trial]:
    """``n`` feedback-only runs of ``duration`` s of seeded random moves at 1 kHz, 18-bit encoders."""
    plant = {"encoder_resolution": ENCODER, **plant}
    return URDFPlant(machine, effects=hidden, seed=seed, **plant).run(
        random_references(machine, n=n, duration=duration, seed=seed))


def _every(trials: list[Trial], k: int) -> list[Trial]:
    """Every k-th sample: a log at 1/k of the plant's rate."""
    return [logs.jittered(tr, tr.fs / k) for tr in trials]


def make_dropouts(seed: int, hidden: tuple):
    """The Panda, 1 kHz, one 21 s run, four logging dropouts of 8.5-8.8 ms, no reference."""
    panda = systems.get(str(PANDA), joints=tuple(f"panda_joint{i}" for i in range(1, 8)))
    run = _run(panda, hidden, seed, 1, 21.0)[0]
    rng = np.random.default_rng(seed)
    gaps = [(t, rng.uniform(0.0085, 0.0088)) for t in sorted(rng.uniform(2.0, 19.0, 4))]
    return panda, [logs.without_reference(logs.drop(run, gaps))]


def make_short(seed: int, hidden: tuple):
    """The cobot at 250 Hz: three runs of 5-6 s (an identification experiment's window)."""
    cobot = _cobot()
    runs = [logs.cut(r, 0.0, 5.0 + 0.5 * k) for k, r in enumerate(_run(cobot, hidden, seed, 3, 6.0))]
    return cobot, _every(runs, 4)


def make_standstill(seed: int, hidden: tuple):
    """The cobot, 1 kHz, three runs of 10 s with 2 s of standstill before and after, the axes held
    while static friction carries an unknown share (up to 1.5 x the Coulomb level) of the load."""
    cobot = _cobot()
    rng = np.random.default_rng(seed)
    levels = 1.5 * np.asarray(COBOT_FRICTION)
    return cobot, [logs.held_at_rest(r, 2.0, 2.0, levels, rng) for r in _run(cobot, hidden, seed, 3, 10.0)]


def make_jittered(seed: int, hidden: tuple):
    """The cobot logged at 100 Hz, each stamp off its grid by up to 4 ms (steps of 2-18 ms), no
    reference, the input with 1 % noise of its RMS (motor currents times drive gains): three runs
    of 20 s."""
    cobot = _cobot()
    rng = np.random.default_rng(seed)
    out = []
    for r in _run(cobot, hidden, seed, 3, 20.0):
        tr = logs.without_reference(logs.jittered(r, 100.0, 0.004, rng))
        tr.u = tr.u + 0.01 * np.sqrt(np.mean(tr.u**2, axis=0)) * rng.standard_normal(tr.u.shape)
        out.append(tr)
    return cobot, out


def make_plain(machine: Callable[[], systems.System], n: int = 3, duration: float = 20.0):
    """A machine's feedback-only runs at 1 kHz, as logged (``n`` runs of ``duration`` s)."""
    def make(seed: int, hidden: tuple):
        m = machine()
        return m, _run(m, hidden, seed, n, duration)
    return make


def make_unsettled(seed: int, hidden: tuple):
    """The cobot's first three joints (the wrist locked): runs that start before the loop has
    settled (no pre-roll: the arm sags under gravity at first) and are cut off mid-move."""
    arm = _cobot(COBOT[:3])
    runs = _run(arm, hidden, seed, 3, 20.0, preroll=0.0)
    out = []
    for r in runs:  # cut where a joint moves fast, in the run's last fifth
        speed = np.abs(np.gradient(r.ref, axis=0)).max(axis=1) * r.fs
        late = np.flatnonzero((speed > 0.5) & (r.t > 0.8 * r.t[-1]))
        out.append(logs.cut(r, 0.0, float(r.t[late[0]]) if late.size else float(r.t[-1])))
    return arm, out


def concave(v):
    """N m over the elbow's speed [rad/s]: a small breakaway level and a rise with sqrt(speed)."""
    return np.tanh(v / 0.005) * (0.8 + 5.0 * np.sqrt(np.abs(v)))


def balancer(q):
    """N m over the two-link shoulder angle [rad]: nothing below 0.2 rad, then a smooth onset
    growing quadratically (a one-sided balancer spring)."""
    x = np.maximum(q - 0.2, 0.0)
    return 12.0 * x**2 * (1.0 - np.exp(-x / 0.05))


def _cobot_friction(joints=COBOT) -> tuple:
    return tuple(fx.CoulombFriction(j, Fc=f, eps=e) for j, (f, e) in zip(joints, COBOT6_FRICTION, strict=False))


def _friction_truth(joints=COBOT) -> tuple:
    return tuple(("friction", j) for j in joints)


LOG_CASES: dict[str, LogCase] = {case.name: case for case in (
    LogCase("logging dropouts (7 joints, 1 kHz, no reference)",
            tuple(fx.CoulombFriction(f"panda_joint{i}", Fc=f, eps=0.005) for i, f in zip(range(4, 8), (2.0, 1.2, 1.0, 0.8),
                                                                                       strict=True)),
            tuple(("friction", f"panda_joint{i}") for i in range(4, 8)), make_dropouts),
    LogCase("three runs of 5-6 s (6 joints, 250 Hz)",
            _cobot_friction() + tuple(fx.RotorInertia(j, J=J) for j, J in zip(COBOT[:3], (0.6, 0.6, 0.3), strict=True)),
            _friction_truth() + (("inertia", "elbow_joint"),), make_short,
            "rotors on the first three joints; the first two are no missing effect: their J qdd lies in the span of the "
            "rigid body (the links' inertias about the same axes), which takes them up"),
    LogCase("standstill held at both ends (6 joints)", _cobot_friction(), _friction_truth(), make_standstill),
    LogCase("100 Hz, jittered stamps, no reference (6 joints)", _cobot_friction(), _friction_truth(), make_jittered),
    LogCase("friction growing with sqrt(speed) (elbow)",
            (fx.TabulatedForce.from_function("elbow_joint", "velocity", concave, -3.2, 3.2, 1024),),
            (("friction", "elbow_joint"),), make_plain(_cobot)),
    LogCase("Coulomb level growing with the gravity load (shoulder, elbow)",
            (fx.LoadFriction("shoulder_lift_joint", Fc=1.0, mu=0.06, eps=0.005),
             fx.LoadFriction("elbow_joint", Fc=0.5, mu=0.06, eps=0.005)),
            (("friction", "shoulder_lift_joint"), ("friction", "elbow_joint")), make_plain(_cobot)),
    LogCase("one-sided spring growing quadratically (two-link shoulder)",
            (fx.TabulatedForce.from_function("shoulder", "position", balancer, -2.6, 2.6, 1024),),
            (("spring", "shoulder"),), make_plain(lambda: systems.get("two_link", joints=("shoulder", "elbow")))),
    LogCase("unsettled start, moves cut off (3 joints)", (fx.CoulombFriction("elbow_joint", Fc=4.0, eps=0.005),),
            (("friction", "elbow_joint"),), make_unsettled),
    LogCase("no hidden effect (6 joints)", (), (), make_plain(_cobot)),
    LogCase("no hidden effect (7 joints, Panda)", (), (),
            make_plain(lambda: systems.get(str(PANDA), joints=tuple(f"panda_joint{i}" for i in range(1, 8))), 2)),
)}


# ---------------------------------------------------------------------------------------------
# Part "runs": what is named must hold on the next run (issue 49)
# ---------------------------------------------------------------------------------------------


def make_faster(seed: int, hidden: tuple):
    """The cobot: three runs of 20 s at a quarter of its joints' speed limits fitted, and one of 20 s
    at half of them (twice as fast) to validate on."""
    cobot = _cobot()
    plant = URDFPlant(cobot, effects=hidden, seed=seed, encoder_resolution=ENCODER)
    train = plant.run(random_references(cobot, n=3, duration=20.0, seed=seed, speed=0.25))
    return cobot, train, plant.run(random_references(cobot, n=1, duration=20.0, seed=seed + 100, speed=0.5))


def make_proportional(seed: int, hidden: tuple):
    """The two-link arm, three runs of 20 s in which the elbow makes half the shoulder's moves."""
    arm = systems.get("two_link", joints=("shoulder", "elbow"))
    refs = []
    for r in random_references(arm, n=3, duration=20.0, seed=seed):
        coupled = [x.copy() for x in (r.positions, r.velocities, r.accelerations)]
        for x, mean in zip(coupled, (r.positions[:, 0].mean(), 0.0, 0.0), strict=True):
            x[:, 1] = 0.5 * (x[:, 0] - mean)
        refs.append(replace(r, positions=coupled[0], velocities=coupled[1], accelerations=coupled[2]))
    return arm, URDFPlant(arm, effects=hidden, seed=seed, encoder_resolution=ENCODER).run(refs), None


def make_repeated(seed: int, hidden: tuple):
    """The cobot: one 20 s trajectory run twice (position noise of 2 encoder steps, a new draw each
    run) fitted, and another 20 s trajectory to validate on."""
    cobot = _cobot()
    same, other = random_references(cobot, n=2, duration=20.0, seed=seed)
    runs = [URDFPlant(cobot, effects=hidden, seed=seed + k, encoder_resolution=ENCODER, noise_rms=2 * ENCODER).run(same)
            for k in range(2)]
    return cobot, runs, [URDFPlant(cobot, effects=hidden, seed=seed + 2, encoder_resolution=ENCODER,
                                   noise_rms=2 * ENCODER).run(other)]


def make_lowpassed(seed: int, hidden: tuple):
    """The cobot logged at 200 Hz (stamps off by up to 1 ms, no reference) by a logger that low-passes
    the torques at 2 Hz and the positions at 3 Hz (causal, second order): three runs of 25 s fitted,
    a fourth validated on."""
    cobot = _cobot()
    rng = np.random.default_rng(seed)
    runs = _run(cobot, hidden, seed, 4, 25.0)
    out = [logs.jittered(logs.without_reference(logs.lowpassed(r, 2.0, 3.0)), 200.0, 0.001, rng) for r in runs]
    return cobot, out[:3], out[3:]


def make_shoulder_alone(seed: int, hidden: tuple):
    """The cobot moving its shoulder alone (the other five joints held in one pose), logged at 125 Hz with seven
    gaps of 10-24 ms per run: three runs of 20 s fitted, a fourth validated on."""
    cobot = _cobot()
    refs, others = [], [0, 2, 3, 4, 5]
    moves = random_references(cobot, n=4, duration=20.0, seed=seed)
    pose = moves[0].positions[0, others]  # the other joints held in one pose throughout
    for r in moves:
        held = [x.copy() for x in (r.positions, r.velocities, r.accelerations)]
        for x, rest in zip(held, (pose, 0.0, 0.0), strict=True):
            x[:, others] = rest
        refs.append(replace(r, positions=held[0], velocities=held[1], accelerations=held[2]))
    rng = np.random.default_rng(seed)
    runs = URDFPlant(cobot, effects=hidden, seed=seed, encoder_resolution=ENCODER).run(refs)
    out = []
    for r in runs:
        gaps = [(t, rng.uniform(0.010, 0.024)) for t in sorted(rng.uniform(1.0, 19.0, 7))]
        out.append(logs.drop(logs.jittered(r, 125.0), gaps))
    return cobot, out[:3], out[3:]


def shoulder_friction(v):
    """N m over the shoulder's speed [rad/s]: a concave friction, a breakaway level of 1 N m and a steep rise
    with the square root of speed (Coulomb alone leaves its curvature)."""
    return np.tanh(v / 0.005) * (1.0 + 8.0 * np.sqrt(np.abs(v)))


@dataclass(frozen=True)
class RunCase:
    """A case of the runs part: ``make(seed, hidden)`` -> (machine, trials fitted, trials to validate
    on or None); ``truth`` the (family, axis) pairs to be named, nothing else."""

    name: str
    hidden: tuple
    truth: tuple[tuple[str, str], ...]
    make: Callable[[int, tuple], tuple[systems.System, list[Trial], list[Trial] | None]]
    note: str = ""


RUN_CASES: dict[str, RunCase] = {case.name: case for case in (
    RunCase("validation run twice as fast (cobot, friction growing with sqrt(speed) on the elbow)",
            (fx.TabulatedForce.from_function("elbow_joint", "velocity", concave, -6.4, 6.4, 1024),),
            (("friction", "elbow_joint"),), make_faster),
    RunCase("one trajectory repeated (cobot, two runs of it fitted; Coulomb friction on every joint)",
            _cobot_friction(), _friction_truth(), make_repeated),
    RunCase("joints driven in proportion (two-link: the elbow makes half the shoulder's moves)",
            (fx.CoulombFriction("elbow", Fc=2.0, eps=0.01),), (("friction", "elbow"),), make_proportional),
    RunCase("torques low-passed at 2 Hz, positions at 3 Hz by the logger (cobot, 200 Hz; Coulomb friction on every "
            "joint)", _cobot_friction(), _friction_truth(), make_lowpassed),
    RunCase("a concave friction, breakaway 1 N m, rising with the square root of speed (cobot, shoulder alone, "
            "125 Hz, gaps)",
            (fx.TabulatedForce.from_function("shoulder_lift_joint", "velocity", shoulder_friction, -6.4, 6.4, 1024),),
            (("friction", "shoulder_lift_joint"),), make_shoulder_alone),
)}


def validation_ratios(report, machine, other) -> tuple[float, float]:
    """The worst ratio, on the validation run, of a joint's residual with the selected effects to the
    rigid-body model's: over the joints that move there, and over all (a joint held in place keeps a
    residual of a few hundredths of N m that a refit of the shared rigid body moves either way)."""
    v = report.validation
    ratios = {a: v["residual_after"][a]["RMS"] / v["residual"][a]["RMS"] for a in machine.axis_names}
    moving = [machine.axis_names[i] for i in moving_axes(other, machine)]
    return max(ratios[a] for a in moving), max(ratios.values())


def run_row(case: RunCase, seeds) -> tuple:
    """One row of the runs part: named right, selected (first seed), the cut on the true axes and what
    the truth allows (``truth_cut``), the worst joint's validation residual with the selected effects
    / without them (the joints that move there; all joints), and the time of a diagnosis."""
    hits, worst, every, cuts, floors, picks, seconds = 0, [], [], [], [], None, 0.0
    for seed in seeds:
        machine, trials, other = case.make(seed, case.hidden)
        t0 = time.perf_counter()
        rep = diagnose(trials, machine, validate=other)
        seconds = max(seconds, time.perf_counter() - t0)
        ok, sel = named(rep, case.truth)
        hits += ok
        picks = picks if picks is not None else (", ".join(sel) or "none")
        cut, floor = truth_cut(case, seed, machine, trials, rep)
        cuts, floors = cuts + cut, floors + floor
        if other is not None:
            moving, everything = validation_ratios(rep, machine, other)
            worst.append(moving)
            every.append(everything)
    span = lambda x: f"{min(x):.2g}-{max(x):.2g}x" if x else "-"  # noqa: E731
    return (case.name, f"{hits} of {len(seeds)}", picks, span(cuts), span(floors), span(worst), span(every),
            f"{seconds:.0f} s")


def runs_part(seeds) -> list[str]:
    return markdown(RUN_CASES, run_row, seeds, ("case", "named right, nothing else", "selected (first seed)",
                                                  "true axes' residual after / before", "the truth allows",
                                                  "worst moving joint on the validation run, with / without the "
                                                  "selected effects", "worst of all joints", "time"))


def markdown(cases: dict, row: Callable, seeds, header: tuple[str, ...]) -> list[str]:
    """The Markdown table of ``row(case, seeds)`` over ``cases``, each row printed as it comes."""
    rows = []
    for case in tqdm(cases.values(), desc="cases"):
        rows.append(row(case, seeds))
        tqdm.write("  ".join(rows[-1]))
    return [f"| {' | '.join(header)} |", "|" + "---|" * len(header)] + [f"| {' | '.join(r)} |" for r in rows]


def named(report, truth) -> tuple[bool, list[str]]:
    """Whether ``report`` named every (family, axis) of ``truth`` and nothing else; its selections."""
    picks = [(c.family, c.axis) for c in report.candidates if c.selected]
    return set(truth) == set(picks) and len(picks) == len(set(picks)), [c.key for c in
                                                                       report.candidates if c.selected]


def truth_cut(case, seed: int, machine, trials, rep) -> tuple[list[float], list[float]]:
    """On the true effects' axes: the residual RMS after / before adding the selected effects, and
    what the truth allows (the same runs without the hidden effects: their residual / before)."""
    axes = sorted({a for _, a in case.truth})
    if not axes:
        return [], []
    cuts = []
    if rep.missing:
        after = diagnose(trials, machine, add=rep.missing).after["residual"]
        cuts = [after[a]["RMS"] / rep.residual[a]["RMS"] for a in axes]
    twin = diagnose(case.make(seed, ())[1], machine)
    return cuts, [twin.residual[a]["RMS"] / rep.residual[a]["RMS"] for a in axes]


def log_row(case: LogCase, seeds) -> tuple:
    """One table row of the logs part: named right, selected (first seed), cut, what the truth allows, time."""
    hits, cuts, floors, picks, seconds = 0, [], [], None, 0.0
    for seed in seeds:
        machine, trials = case.make(seed, case.hidden)
        t0 = time.perf_counter()
        rep = diagnose(trials, machine)
        seconds = max(seconds, time.perf_counter() - t0)
        ok, sel = named(rep, case.truth)
        hits += ok
        picks = picks if picks is not None else (", ".join(sel) or "none")
        cut, floor = truth_cut(case, seed, machine, trials, rep)
        cuts, floors = cuts + cut, floors + floor
    span = lambda x: f"{min(x):.2g}-{max(x):.2g}x" if x else "-"  # noqa: E731  (2 digits: a floor may be 0.003x)
    return case.name, f"{hits} of {len(seeds)}", picks, span(cuts), span(floors), f"{seconds:.0f} s"


def logs_part(seeds) -> list[str]:
    return markdown(LOG_CASES, log_row, seeds, ("case (URDF arm)", "named right, nothing else", "selected (first seed)",
                                                "true axes' residual after / before", "the truth allows", "time"))


def ix_none(seeds) -> str:
    """The IX with no hidden effect: how often nothing is selected."""
    nothing = sum(not diagnose(IXPlant(effects=()).run(reference_set("train", seed, 3)), IX).missing for seed in seeds)
    return f"| no hidden effect | nothing selected, {nothing} of {len(seeds)} | | | |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("ix", "logs", "runs", "all"), default="all")
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--out", type=Path, help="write the table(s) as Markdown")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    tables = []
    if args.part in ("logs", "all"):
        tables.append("\n".join(logs_part(seeds)))
        print(tables[-1])
    if args.part in ("runs", "all"):
        tables.append("\n".join(runs_part(seeds)))
        print(tables[-1])
    if args.part in ("ix", "all"):
        tables.append(ix_part(seeds))
    if args.out:
        atomic_write(args.out, lambda tmp: Path(tmp).write_text("\n\n".join(tables) + "\n"))
        print(f"wrote {args.out}")


def ix_part(seeds) -> str:
    refs0 = reference_set("train", 0, 3)
    cases = {**OTHER_SHAPES, **pairs(refs0)}
    rows = []
    for name, (hidden, truth) in tqdm(cases.items(), desc="cases"):
        hits, cuts, picks, seconds = 0, [], None, 0.0
        for seed in seeds:
            runs = IXPlant(effects=hidden).run(reference_set("train", seed, 3))
            t0 = time.perf_counter()
            rep = diagnose(runs, IX)
            seconds = max(seconds, time.perf_counter() - t0)
            picks = picks or (", ".join(rep.missing) or "none")
            if isinstance(truth[0], str) and "@" in truth[0]:  # a pair: both among the first two picks
                hits += set(truth) <= set(rep.missing[:2])
                axes = {k.split("@")[1] for k in truth}
            else:
                first = rep.candidates[0] if rep.candidates else None
                hits += first is not None and (first.family, first.axis) == truth
                axes = {truth[1]}
            if rep.missing:
                after = diagnose(runs, IX, add=rep.missing).after["residual"]
                cuts += [after[a]["RMS"] / rep.residual[a]["RMS"] for a in axes]
        cut = f"{min(cuts):.2f}-{max(cuts):.2f}x" if cuts else "-"
        rows.append((name, f"{hits} of {len(seeds)}", picks, cut, f"{seconds:.0f} s"))
        tqdm.write(f"{name:66s} {rows[-1][1]:>7s}  {cut:12s} {picks}")
    lines = ["| hidden (IX plant) | named first | selected (seed 0) | residual RMS after / before | time |",
             "|---|---|---|---|---|"] + [f"| {' | '.join(r)} |" for r in rows] + [ix_none(seeds)]
    print("\n".join(lines))
    return "\n".join(lines)


if __name__ == "__main__":
    main()
