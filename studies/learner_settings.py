"""What each learner needs of a machine (issue 60): the experiments behind the settings of
``methods/pgnn``, ``methods/rbf_expert``, ``methods/rl`` and ``methods/ilc`` on the benchmark's data
(8 training references of 40 s, 4 validation references, one seed; a cell of ``lcgym bench`` but
for the variant named). Each row prints the validation RMS tracking error per scored axis [deg,
or mm on a prismatic axis; the FlexArm's TCP in mm last] and what the method's safeguard dropped.

Parts (``--parts``, default all but ``armseeds`` and ``armrule``):

* ``ilc``: the EMPS's ILC with Q on the whole feedforward (before issue 60) and on what it learns:
  the base carries the velocity loop's term, whose steps a 5 Hz Q rounds off;
* ``pgnn``: the PGNN on EMPS-v0 trained on feedback-only runs or on runs with the base on, u
  low-passed at 1, 5 or 20 Hz or not at all;
* ``oracle``: on the FlexArm, the base's measured input run as the feedforward of its own training
  reference, as measured and low-passed at 10, 5 and 2 Hz (what a network that learned it exactly
  would give; the load error of the moving joints [urad]);
* ``flexarm``: pgnn and pgnn-ls on the FlexArm (R1 keeps pgnn's network out of the model's span);
* ``rbf``: the RBF expert with Table 3's four experts and with the cruise and rest experts, and with
  Table 1's motion influence as the paper has it (``influence.TOGETHER`` 0) or with independent
  joints unmixed, on every machine;
* ``rl``: RL with the env's fixed scales and with the scales from the base (``RLConfig.scaled``),
  on the two-link arm and the EMPS;
* ``armlimits``: on the FlexArm, where the RBF expert and RL take little of the learnable: eq. (17)'s
  one step with the validation line's own measured e_pl (a perfect predictor) against the
  prediction, with how much of e_pl's energy the prediction explains; and RL with 1 and 5 passes;
* ``armseeds``: on the FlexArm (run it with ``--seed 1`` and ``--seed 2``), the PGNN and the RBF
  expert with their safeguards off: what the safeguard's every-training-line rule dropped;
* ``armrule``: on the FlexArm (any seed), every learner under a looser safeguard rule than the
  benchmark's: an axis is kept where its error over the training lines falls and no line's rises
  above 1.05x the base's (``LOOSE``);
* ``armjerk``: on the FlexArm (any seed), the PGNN and the PGNN (J_LS) with the reference's jerk and
  snap among the network's inputs (``PGNNConfig.derivatives = 4``);
* ``armtorsion``: on the FlexArm (any seed), where the arm's learnable lies: the base on the
  validation lines with a perfect torque (the base's own measured input on the line, as ``oracle``)
  and with the true gear torsion as its reference offset (the true plant's load torque over its
  true joint stiffness, where the base has its fitted model's over the nominal stiffness), and the
  base with its motor inertias held at the nominal (datasheet) values instead of fitted;
* ``armquick``: on the quick bench's FlexArm cell (2 training and 2 validation lines), the RBF
  expert's safeguard figures per training line (tracking error and input residual, base and
  correction) against the validation lines': what a safeguard judging the input residual too would
  have seen.

Run:  .venv/bin/python studies/learner_settings.py [--parts ilc,pgnn,oracle,flexarm,rbf,rl,armlimits] [--seed 0]
      .venv/bin/python studies/learner_settings.py --parts armseeds --seed 1   (and --seed 2)
      .venv/bin/python studies/learner_settings.py --parts armrule --seed 0   (and 1, 2; armjerk, armtorsion too)
(about 30 minutes for the default parts, 5 for armseeds with one seed, on a 2-core machine with other work beside it, 2026-12-07.)
"""

from __future__ import annotations

import argparse
import copy
from dataclasses import replace

import numpy as np
import pandas as pd

from lcgym import systems
from lcgym.methods import IterativeLearningControl, PhysicalFeedforward, RBFExpertFeedforward, RLFeedforward
from lcgym.methods.bases import closed_loop
from lcgym.methods.pgnn.method import PGNNFeedforward, PGNNLSFeedforward
from lcgym.methods.protocol import evaluate
from lcgym.methods.rbf_expert import influence
from lcgym.methods.rbf_expert.predictor import RBFExpertConfig
from lcgym.methods.rl import RLConfig
from lcgym.physics.kinematics import lowpass_zero_phase
from lcgym.systems.runs import remembered_runs

PARTS = ("ilc", "pgnn", "oracle", "flexarm", "rbf", "rl", "armlimits", "armseeds", "armrule", "armjerk", "armtorsion",
         "armquick")
ARM_ONLY = ("armseeds", "armrule", "armjerk", "armtorsion", "armquick")  # not run by default


class Cell:
    """One machine's benchmark data for a seed: its bench, training runs and references."""

    def __init__(self, name: str, seed: int):
        self.machine = systems.resolve(name)
        self.bench = self.machine.system.make_bench()
        self.refs = {s: self.bench.references(s, seed, n, 40.0) for s, n in (("train", 8), ("validation", 4))}
        self.train = self.bench.run(self.refs["train"])

    def score(self, label: str, method) -> None:
        """Fit and apply ``method`` as a cell does; print its validation errors and its note."""
        with remembered_runs():
            _, out = evaluate(method, self.bench, copy.deepcopy(self.train), {"validation": self.refs["validation"]})
        tables = pd.concat(out["validation"].tables)
        rows = tables[tables["signal"].isin(["tracking_error", "tcp_position_error"]) & (tables["period"] == "all")]
        axes = " ".join(f"{a} {v:.4g} {u}" for a, v, u in zip(rows["axis"], rows["RMS"], rows["unit"], strict=True))
        note = getattr(method, "note_", "")
        print(f"  {label:44s} {axes}" + (f"  [{note[:110]}]" if note else ""), flush=True)


def part_ilc(seed: int) -> None:
    """ILC's Q on the whole feedforward (the update before issue 60) against Q on the correction."""
    print("ilc: EMPS-v0, 10 trials per validation reference, from the base with the velocity loop's term")
    cell = Cell("emps_sim", seed)
    cell.score("physical (the base)", PhysicalFeedforward(system=cell.machine.system))
    cell.score("ilc, Q on what it learns", IterativeLearningControl(system=cell.machine.system))
    from lcgym.systems import learning

    whole = IterativeLearningControl(system=cell.machine.system)
    on_correction = learning.TrackingLoop.update

    def on_whole(loop, state, measured):  # f_j+1 = Q (f_j + L e_j): Q filters the base's feedforward too
        e = learning.deadzone(measured.error, 0.5 * np.asarray(loop.law.plant.encoder_resolution))
        q_of_all = learning.frequency_update(state, e, loop.inverse, loop.q, loop.law.config.gain)
        return loop.start + loop.fade * (q_of_all - loop.start)

    learning.TrackingLoop.update = on_whole
    try:
        cell.score("ilc, Q on the whole feedforward (before)", whole)
    finally:
        learning.TrackingLoop.update = on_correction


def part_pgnn(seed: int) -> None:
    print("pgnn: EMPS-v0, the data it is trained on and the low-pass of u")
    cell = Cell("emps_sim", seed)
    cell.score("physical (the base)", PhysicalFeedforward(system=cell.machine.system))
    for collect in ("feedback", "physical"):
        for hz in (1.0, 5.0, 20.0, None):
            method = PGNNFeedforward(system=cell.machine.system, collect=collect)
            config = method.training_config
            method.training_config = lambda n=8, config=config, hz=hz: replace(config(n), filter_hz=hz)
            cell.score(f"pgnn, {collect} runs, u at {hz or 'full band'} Hz", method)


def part_oracle(seed: int) -> None:
    print("oracle: FlexArm-v1, the base's measured input run as the feedforward of its own training reference "
          "(load error of j2, j3, j5 [urad])")
    cell = Cell("flexarm", seed)
    base = PhysicalFeedforward(system=cell.machine.system).fit(cell.train)
    moving = list(cell.bench.scored)
    for r in cell.refs["train"][:3]:
        f, o = base.feedforward(r), base.reference_offset(r)
        run = closed_loop(cell.bench.plant, r, f, o)

        def load(trial) -> str:
            e = cell.bench.tracking_error(trial)[:, moving]
            return " ".join(f"{x:6.1f}" for x in 1e6 * np.sqrt(np.mean(e**2, axis=0)))

        print(f"  {r.name}: base {load(run)}", flush=True)
        for hz in (None, 10.0, 5.0, 2.0):
            u = run.u if hz is None else lowpass_zero_phase(run.u, run.fs, hz)
            print(f"    measured u as feedforward, {hz or 'full band'} Hz: {load(closed_loop(cell.bench.plant, r, u, o))}",
                  flush=True)


def part_flexarm(seed: int) -> None:
    print("flexarm: FlexArm-v1, pgnn (J: R1 keeps the network out of the model's span) and pgnn-ls (J_LS)")
    cell = Cell("flexarm", seed)
    cell.score("physical (the base)", PhysicalFeedforward(system=cell.machine.system))
    cell.score("ilc", IterativeLearningControl(system=cell.machine.system))
    cell.score("pgnn", PGNNFeedforward(system=cell.machine.system))
    cell.score("pgnn-ls", PGNNLSFeedforward(system=cell.machine.system))


def uncovered(cell: Cell) -> str:
    """Share of the base's tracking-error energy on the validation references where Table 3
    activates no network (long constant velocity, or at rest), per moving joint."""
    method = RBFExpertFeedforward(RBFExpertConfig(cruise_and_rest=False), system=cell.machine.system).fit(cell.train)
    method._train(cell.bench.plant)
    predictor, shares = method.predictor_, []
    for j in predictor.joints:
        energy = np.zeros(2)
        for r in cell.refs["validation"]:
            trial = closed_loop(cell.bench.plant, r, *method._start(r))
            e2 = cell.bench.tracking_error(trial)[:, j] ** 2
            types = predictor.inputs(r, j)[1]
            energy += e2[types == 0].sum(), e2.sum()
        shares.append(f"{trial.axes[j]} {100 * energy[0] / energy[1]:.0f} %")
    return ", ".join(shares)


def part_rbf(seed: int) -> None:
    print("rbf: the experts beyond Table 3 and the motion influence of joints that move independently")
    together = influence.TOGETHER
    for name in ("two_link", "emps_sim", "ix", "flexarm"):
        cell = Cell(name, seed)
        print(f" {cell.machine.name}")
        if name != "flexarm":  # the arm's predictor learns the model-following error, an acceleration
            print(f"  the base's tracking-error energy where Table 3 has no network: {uncovered(cell)}", flush=True)
        cell.score("physical (the base)", PhysicalFeedforward(system=cell.machine.system))
        for experts in (False, True):
            for unmixed in (False, True):
                influence.TOGETHER = together if unmixed else 0.0
                label = (f"rbf-expert, {'+ cruise, rest' if experts else 'Table 3'}, "
                         f"{'independent joints unmixed' if unmixed else 'Table 1'}")
                cell.score(label, RBFExpertFeedforward(RBFExpertConfig(cruise_and_rest=experts), system=cell.machine.system))
        influence.TOGETHER = together


def part_rl(seed: int) -> None:
    print("rl: the env's fixed scales against scales from the base (RLConfig.scaled)")
    for name in ("two_link", "emps_sim"):
        cell = Cell(name, seed)
        print(f" {cell.machine.name}")
        cell.score("physical (the base)", PhysicalFeedforward(system=cell.machine.system))
        for scaled in (False, True):
            cell.score(f"rl, {'scales from the base' if scaled else 'fixed scales'}",
                       RLFeedforward(RLConfig(scaled=scaled, cache=False), system=cell.machine.system))


def part_armlimits(seed: int) -> None:
    from lcgym.methods.ilc.method import ILCConfig
    from lcgym.systems.learning import Signals

    print("armlimits: FlexArm-v1, TCP error [mm] of the validation lines; the RBF expert's eq. (17) with e_pl "
          "measured or predicted; RL's budget")
    cell = Cell("flexarm", seed)
    plant, bench = cell.bench.plant, cell.bench
    cell.score("ilc (the bound)", IterativeLearningControl(system=cell.machine.system))
    method = RBFExpertFeedforward(system=cell.machine.system).fit(cell.train)
    method.law_ = plant.learning_law(method.base, ILCConfig())
    method._train(plant)
    moving = list(bench.scored)
    tcp = {"base": [], "eq. (17), measured e_pl": [], "eq. (17), predicted e_pl": []}
    explained = []
    for r in cell.refs["validation"]:
        f0, o0 = method._start(r)
        base = closed_loop(plant, r, f0, o0)
        loop = method.law_.loop(r, Signals(f0, o0))
        e_pl = loop.model_error(base, loop.start)
        e_hat = method.predict(r)
        explained.append((np.sum((e_hat - e_pl)[:, moving] ** 2, axis=0), np.sum(e_pl[:, moving] ** 2, axis=0)))
        for label, run in (("base", base),
                           ("eq. (17), measured e_pl", closed_loop(plant, r, *loop.predicted(e_pl))),
                           ("eq. (17), predicted e_pl", closed_loop(plant, r, *loop.predicted(e_hat)))):
            tcp[label].append(bench.tcp_error(run))
    for label, errors in tcp.items():
        print(f"  {label:44s} tcp {np.sqrt(np.mean(np.concatenate(errors) ** 2)):.4g} mm", flush=True)
    left, energy = (np.sum(x, axis=0) for x in zip(*explained, strict=True))
    print("  share of e_pl's energy the prediction explains on the validation lines (j2 j3 j5): "
          + " ".join(f"{1 - a / b:.2f}" for a, b in zip(left, energy, strict=True)), flush=True)
    for passes in (1.0, 5.0):
        cell.score(f"rl, {passes:g} passes", RLFeedforward(RLConfig(passes=passes, cache=False), system=cell.machine.system))


def part_armseeds(seed: int) -> None:
    print(f"armseeds: FlexArm-v1, seed {seed}, the PGNN and the RBF expert with and without their safeguards")
    cell = Cell("flexarm", seed)
    cell.score("physical (the base)", PhysicalFeedforward(system=cell.machine.system))
    cell.score("ilc (the bound)", IterativeLearningControl(system=cell.machine.system))
    for guarded in (True, False):
        pgnn = PGNNFeedforward(system=cell.machine.system)
        rbf = RBFExpertFeedforward(system=cell.machine.system)
        pgnn.gate, rbf.safeguard = guarded, guarded
        cell.score(f"pgnn, safeguard {'on' if guarded else 'off'}", pgnn)
        cell.score(f"rbf-expert, safeguard {'on' if guarded else 'off'}", rbf)


LOOSE = 1.05


def part_armrule(seed: int) -> None:
    from lcgym.methods import rl as rl_module
    from lcgym.methods import safeguard

    strict = safeguard.keep_axes

    def loose(base, learned, masked_rms, scored, n_axes, learned_key="learned"):
        ok = (learned <= LOOSE * base).all(axis=0) & (np.sqrt(np.mean(learned**2, axis=0))
                                                       < np.sqrt(np.mean(base**2, axis=0)))
        kept = safeguard.action_axes(ok, scored, n_axes) if ok.any() else np.zeros(n_axes, dtype=bool)
        return kept, {"base": base, learned_key: learned}

    print(f"armrule: FlexArm-v1, seed {seed}, every learner with the looser rule (no training line above {LOOSE}x)")
    cell = Cell("flexarm", seed)
    cell.score("physical (the base)", PhysicalFeedforward(system=cell.machine.system))
    cell.score("ilc (the bound)", IterativeLearningControl(system=cell.machine.system))
    safeguard.keep_axes = rl_module.keep_axes = loose  # rl imported the rule by name
    try:
        for label, method in (("pgnn", PGNNFeedforward(system=cell.machine.system)),
                              ("pgnn-ls", PGNNLSFeedforward(system=cell.machine.system)),
                              ("rbf-expert", RBFExpertFeedforward(system=cell.machine.system)),
                              ("rl", RLFeedforward(RLConfig(cache=False), system=cell.machine.system))):
            cell.score(f"{label}, looser rule", method)
    finally:
        safeguard.keep_axes = rl_module.keep_axes = strict


def part_armjerk(seed: int) -> None:
    print(f"armjerk: FlexArm-v1, seed {seed}, the PGNN with the reference's jerk and snap among its network's inputs")
    cell = Cell("flexarm", seed)
    cell.score("physical (the base)", PhysicalFeedforward(system=cell.machine.system))
    for cls in (PGNNFeedforward, PGNNLSFeedforward):
        method = cls(system=cell.machine.system)
        config = method.training_config
        method.training_config = lambda n=8, config=config: replace(config(n), derivatives=4)
        cell.score(f"{cls.name}, inputs with jerk and snap", method)


def part_armtorsion(seed: int) -> None:
    from lcgym.physics.kinematics import reference_kinematics
    from lcgym.systems.flexarm import dynamics as arm

    print(f"armtorsion: FlexArm-v1, seed {seed}, the base on the validation lines with a perfect torque and with the "
          "true gear torsion (RMS over the lines: load error of j2, j3, j5 [urad], TCP [mm])")
    cell = Cell("flexarm", seed)
    plant, bench, moving = cell.bench.plant, cell.bench, list(cell.bench.scored)
    base = PhysicalFeedforward(system=cell.machine.system).fit(cell.train)
    jm = np.asarray(base._model().params_.Jm) / np.asarray(arm.DriveParameters().Jm)
    print("  the base's fitted motor inertia over the nominal, j2 j3 j5: " + " ".join(f"{x:.2f}" for x in jm[moving]))

    def true_torsion(r) -> np.ndarray:
        q, qd, qdd = reference_kinematics(r.positions, r.fs, cell.machine.system.advance)
        return arm.load_torque(plant.true_arm, plant.true_drive, q, qd, qdd, plant.friction_eps) / np.asarray(plant.true_drive.KJ)

    rows: dict[str, list] = {}
    for r in cell.refs["validation"]:
        f, o = base.feedforward(r), base.reference_offset(r)
        run = closed_loop(plant, r, f, o)
        u = lowpass_zero_phase(run.u, run.fs, 10.0)
        once = closed_loop(plant, r, u, o)
        for label, trial in (("base", run),
                             ("perfect torque (its measured u at 10 Hz)", once),
                             ("the same, twice (the measured u of that run)",
                              closed_loop(plant, r, lowpass_zero_phase(once.u, run.fs, 10.0), o)),
                             ("true torsion offset", closed_loop(plant, r, f, true_torsion(r))),
                             ("both", closed_loop(plant, r, u, true_torsion(r)))):
            rows.setdefault(label, []).append((bench.tracking_error(trial)[:, moving], bench.tcp_error(trial)))
    for label, parts in rows.items():
        joints = np.sqrt(np.mean(np.concatenate([j for j, _ in parts]) ** 2, axis=0))
        tcp = np.sqrt(np.mean(np.concatenate([t for _, t in parts]) ** 2))
        print(f"  {label:44s} " + " ".join(f"{x:6.1f}" for x in 1e6 * joints) + f"  tcp {tcp:.4g} mm", flush=True)
    cell.score("ilc (the bound)", IterativeLearningControl(system=cell.machine.system))
    cell.score("the base with its motor inertia held nominal", PhysicalFeedforward(model=nominal_jm(cell)))


def nominal_jm(cell: Cell):
    """The FlexArm's physical model with the motor inertias held at their nominal (datasheet) values."""
    import dataclasses

    from lcgym.systems.flexarm import motor
    from lcgym.systems.flexarm.model import ArmModel

    class NominalJm(ArmModel):
        def free_mask(self) -> np.ndarray:
            free = super().free_mask()
            free[motor.N_PI : motor.N_PI + motor.N] = False
            return free

    model = cell.machine.system.physical_model(fs=cell.train[0].fs)
    return NominalJm(**{f.name: getattr(model, f.name) for f in dataclasses.fields(model) if f.init})


def part_armquick(seed: int) -> None:
    from lcgym.methods import safeguard

    print(f"armquick: FlexArm-v1, the quick bench's cell (seed {seed}, 2 training lines), the RBF expert; RMS per "
          "line of j2 j3 j5: load error [urad], input residual [N m]")
    machine = systems.resolve("flexarm")
    bench = machine.system.make_bench()
    refs = {s: bench.references(s, seed, 2, 20.0) for s in ("train", "validation")}
    judged = safeguard.Safeguard._rms

    def rms(guard, plant, references, base, learned, kept, scored):
        out = judged(guard, plant, references, base, learned, kept, scored)
        for r, tracking in zip(references, out, strict=True):
            f, o = safeguard.mixed(base(r), learned(r), kept)
            residual = np.sqrt(np.mean((closed_loop(plant, r, f, o).u - f)[:, scored] ** 2, axis=0))
            print(f"  training {r.name}, {'correction' if kept.any() else 'base'}: load error "
                  + " ".join(f"{x:6.1f}" for x in 1e6 * tracking) + ", input residual "
                  + " ".join(f"{x:.3f}" for x in residual), flush=True)
        return out

    safeguard.Safeguard._rms = rms
    try:
        results = {}
        for label, method in (("base", PhysicalFeedforward(system=machine.system)),
                              ("rbf-expert", RBFExpertFeedforward(system=machine.system))):
            with remembered_runs():
                _, out = evaluate(method, bench, bench.run(refs["train"]), {"validation": refs["validation"]})
            tables = pd.concat(out["validation"].tables)
            rows = tables[(tables["period"] == "all") & tables["signal"].isin(["tracking_error", "input_residual"])]
            results[label] = rows.set_index(["signal", "axis"])["RMS"]
    finally:
        safeguard.Safeguard._rms = judged
    ratio = results["rbf-expert"] / results["base"]
    print("  validation, rbf-expert over its base: "
          + ", ".join(f"{sig} {ax} {v:.2f}x" for (sig, ax), v in ratio.items()), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", default=",".join(p for p in PARTS if p not in ARM_ONLY))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    parts = args.parts.split(",")
    unknown = [p for p in parts if p not in PARTS]
    if unknown:
        parser.error(f"unknown part {unknown[0]!r}; parts: {', '.join(PARTS)}")
    for p in parts:
        globals()[f"part_{p}"](args.seed)


if __name__ == "__main__":
    main()
