"""``diagnose(trials)``: compare the model with measurements, see where it fails, find the
missing effect, add it and watch the error fall. The steps, in order:

1. Compare: the system's nominal physical model (``for_diagnosis``: IX rigid body + viscous
   friction; FlexArm CAD rigid body + fitted motor inertia and viscous friction) is fitted to the
   trials by least squares (``positions="measured"``: the motion the machine made, see
   ``physics/model.py``); residual = u - f_model after the model's own
   low-pass and decimation (5 Hz zero phase, so the quantization noise that the feedback puts
   into u above that is not counted). MA, RMS, Inf per axis in the input's unit.
2. Where it fails: the residual by operating region (``regions.py``).
3. What is missing: every candidate effect on every axis, scored on held-out data, greedy
   forward selection (``search.py``); candidates that pass the significance rule, best first.
4. Add it: ``add=["coulomb_friction@roll", ...]`` refits the model with those effects (their
   nonlinear parameters as the search found them for the effect alone, step 3) and gives the
   residual after, computed the same way;
   ``replay`` re-runs the plant the data came from with the feedforward of the model before and
   after and compares the tracking errors.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from tqdm.auto import tqdm

from ..leaderboard.metrics import norms as metric_norms
from ..physics import arm_motor
from ..physics.effects import Effect, make_effect
from ..physics.kinematics import reference_kinematics
from ..physics.model import PhysicalModel
from ..physics.registry import MODELS
from ..physics.system import SYSTEMS
from .candidates import Candidate, candidates_for
from .regions import region_masks, region_table
from .report import Diagnosis
from .search import check_length, prepare, rank

DEG = math.pi / 180.0


def norms(x: np.ndarray, axes: Sequence[str], unit: str) -> dict:
    """{axis: {MA, RMS, Inf, unit}} of a residual (R, A)."""
    n = metric_norms(x)
    return {ax: {**{k: float(v[i]) for k, v in n.items()}, "unit": unit} for i, ax in enumerate(axes)}


def _check_trials(trials, system) -> None:
    if not trials:
        raise ValueError("diagnose: no trials given")
    for k, tr in enumerate(trials):
        if tuple(tr.axes) != tuple(system.axes):
            raise ValueError(f"diagnose: trial {k} has axes {tr.axes}, system {system.name} has {system.axes}")
        if abs(tr.fs - trials[0].fs) > 1e-6 * trials[0].fs:
            raise ValueError(f"diagnose: trial {k} is sampled at {tr.fs:g} Hz, trial 0 at {trials[0].fs:g} Hz")


@arm_motor.cached_regressors()  # the arm's model, its effects and its refits share their regressors
def diagnose(trials: Sequence, system: str = "ix", add: Sequence[str | Effect] = (), replay: bool = False,
             candidates: Sequence[Candidate] | None = None, model: PhysicalModel | None = None,
             min_explained: float = 0.1, min_rms: float | None = None, block_seconds: float = 4.0,
             max_steps: int | None = None, progress: bool = False) -> Diagnosis:
    """Run the workflow of this module on measured ``trials`` of ``system``.

    model: the physical model to diagnose (unfitted; default the system's nominal one).
    candidates: effects to try (default every registered one, ``candidates.CANDIDATES``).
    min_explained, min_rms [input unit]: the significance rule (``search.py``); min_rms
    defaults to the system's ``noise_rms``. add: effects (``name@axis`` or Effect objects)
    to add after the search. replay: re-run the plant recorded in the trials' metadata.
    Candidates are tried on the axes that move (reference range above ``MIN_TRAVEL``: a joint that
    stands still shows neither friction nor inertia); max_steps: most effects selected (default
    two per moving axis).
    """
    if system not in SYSTEMS:
        raise ValueError(f"unknown system {system!r}; choose one of {sorted(SYSTEMS)}")
    sysd = SYSTEMS[system]
    _check_trials(trials, sysd)
    if not 0.0 < min_explained < 1.0:
        raise ValueError(f"min_explained must be in (0, 1), got {min_explained}")
    axes, unit = tuple(sysd.axes), sysd.input_unit
    min_rms = sysd.noise_rms if min_rms is None else float(min_rms)
    fs = trials[0].fs
    model = model if model is not None else MODELS[system].for_diagnosis(fs)
    cands = candidates_for(system) if candidates is None else list(candidates)
    added = [_parse_add(a, model, system) for a in add]  # every check before the work
    keys = [e.key for e in added]
    if len(set(keys)) < len(keys):
        raise ValueError(f"an effect is added twice: {keys}")
    if replay and not isinstance(trials[0].meta.get("plant"), dict):
        raise ValueError("--replay needs data simulated by lcgym: the file's sidecar has no 'plant' record")
    check_length(trials, block_seconds)
    moving = moving_axes(trials)
    if not moving:
        raise ValueError(f"diagnose: no axis moves more than {np.degrees(MIN_TRAVEL):g} deg in the data")
    max_steps = 2 * len(moving) if max_steps is None else max_steps

    bar = tqdm(total=2, desc="diagnose", disable=not progress, leave=False)
    bar.set_postfix_str("fit nominal model")
    ref_velocity = np.concatenate([reference_kinematics(tr.ref, fs)[1] for tr in trials])
    prep = prepare(trials, model, block_seconds)
    bar.update()
    residual = prep.residual
    q, qd, qdd = (k[prep.rows] for k in prep.kin)
    fs_rows = fs / max(1, prep.model.decimate)
    regions = region_table(residual, region_masks(q, qd, qdd, prep.trial, fs_rows, axes), axes)
    bar.update()
    bar.set_postfix_str("candidates")
    ranking = rank(prep, trials, cands, axes, min_explained=min_explained, min_rms=min_rms,
                   block_seconds=block_seconds, max_steps=max_steps, progress=bar, search_axes=moving)
    bar.close()

    rows = []
    alone = {(s.candidate.name, s.axis): s for s in ranking.alone}
    for s, share in ranking.selected:  # explained and RMS_after of the effect alone, as for the rest
        rows.append(_candidate_row(ranking, alone.get((s.candidate.name, s.axis), s), axes, unit, selected=True, step=share))
    picked = {(s.candidate.name, s.axis) for s, _ in ranking.selected}
    rest = [s for s in ranking.alone if (s.candidate.name, s.axis) not in picked and ranking.passes_alone(s)]
    for s in sorted(rest, key=lambda s: -ranking.explained(s)):
        rows.append(_candidate_row(ranking, s, axes, unit, selected=False, step=None))

    report = Diagnosis(system=system, axes=axes, unit=unit, n_samples=sum(prep.lengths), fs=fs,
                       model_effects=[*prep.model.parts(), *(e.key for e in prep.model.effects)],
                       residual=norms(residual, axes, unit), regions=regions, candidates=rows,
                       min_explained=min_explained, min_rms=min_rms, model=prep.model, suggested_model=ranking.model,
                       series={"t": prep.rows / fs, "residual": residual, "q": q, "qd": qd,
                               "ref_velocity": ref_velocity[prep.rows]})
    report.found = {f"{s.candidate.name}@{axes[s.axis]}": s.candidate.build(axes[s.axis], **s.params)
                    for s in ranking.alone}
    if added:
        effects = [report.found.get(e.key, e) if isinstance(a, str) else e for a, e in zip(add, added, strict=True)]
        after_model = prep.model
        for e in effects:
            after_model = after_model.with_effect(e)
        after = prepare(trials, after_model, block_seconds)
        report.after = {"added": [e.key for e in effects], "residual": norms(after.residual, axes, unit),
                        "effects": [_effect_params(e) for e in after.model.fitted_effects]}
        report.after_model = after.model
        report.series["residual_after"] = after.residual
    if replay:
        after_model = report.after_model if report.after_model is not None else report.suggested_model
        report.replay = replay_tracking(trials, report.model, after_model)
    return report


MIN_TRAVEL = 1.0 * DEG  # rad: an axis whose reference spans less stands still


def moving_axes(trials: Sequence) -> list[int]:
    """Indices of the axes whose reference spans at least ``MIN_TRAVEL`` over the trials."""
    ref = np.concatenate([tr.ref for tr in trials])
    return [i for i in range(ref.shape[1]) if np.ptp(ref[:, i]) >= MIN_TRAVEL]


def _parse_add(item, model: PhysicalModel, system: str) -> Effect:
    """An effect to add: an Effect, or a ``name@axis`` label of a candidate."""
    if isinstance(item, Effect):
        return item
    name = str(item).partition("@")[0]
    if name in model.parts():
        raise ValueError(f"cannot add {item}: the model already has {name}")
    available = [c.name for c in candidates_for(system)]
    if name not in available:
        raise ValueError(f"cannot add {item}: {name!r} is not an effect diagnose can add on {system}; choose from "
                         f"{', '.join(available)} (`lcgym effects --system {system}`)")
    return make_effect(str(item))


def _effect_params(e: Effect) -> dict:
    return {"effect": e.key, **{n: float(getattr(e, n)) for n in (*e.linear, *e.nonlinear)}}


def _candidate_row(ranking, s, axes, unit, selected: bool, step: float | None) -> dict:
    cand = s.candidate
    return {"effect": cand.name, "axis": axes[s.axis], "family": cand.family, "explained": ranking.explained(s),
            "RMS_before": math.sqrt(ranking.baseline[s.axis] / ranking.n_rows),
            "RMS_after": math.sqrt(s.held_out_sse / ranking.n_rows), "unit": unit, "selected": selected,
            "explained_at_selection": step, "parameters": {k: float(v) for k, v in s.params.items()}}


def replay_tracking(trials: Sequence, before: PhysicalModel, after: PhysicalModel) -> dict:
    """Re-run the plant recorded in the trials' metadata on their references with the
    feedforward of ``before`` and of ``after``; tracking-error RMS per axis [deg]."""
    from ..envs import plant_from_record

    record = trials[0].meta.get("plant")
    if not isinstance(record, dict):
        raise ValueError("--replay needs data simulated by lcgym: the file's sidecar has no 'plant' record")
    plant = plant_from_record(record)
    refs = [tr.ref for tr in trials]
    out = {}
    for label, m in (("before", before), ("after", after)):
        runs = plant.run(refs, [m.predict(r) for r in refs])
        e = np.concatenate([r.error for r in runs])
        out[label] = {ax: float(np.degrees(np.sqrt(np.mean(e[:, i] ** 2)))) for i, ax in enumerate(trials[0].axes)}
    out["unit"] = "deg"
    return out
