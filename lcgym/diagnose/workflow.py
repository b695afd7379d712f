"""``diagnose(trials, system)``: compare the model with measurements, see where it fails, find the
missing effect, add it and watch the error fall, on any machine (``systems.System``: a built-in
one, a URDF, a user's Python class). The steps, in order:

1. Compare: the machine's nominal physical model (``System.diagnosis_model``: IX rigid body +
   viscous friction; FlexArm CAD rigid body + fitted motor inertia and viscous friction; a URDF
   or user machine: its rigid body + viscous friction on every axis) is fitted to the trials by
   least squares, on the motion the machine made (``kinematics="reference"``: the reference
   corrected by the measured tracking error, see ``physics/model.py``; ``"measured"``, or a log
   without a reference: the measured position, low-passed and differentiated); residual = u -
   f_model after the model's own low-pass and decimation (5 Hz zero phase, so the quantization
   noise that the feedback puts into u above that is not counted). MA, RMS, Inf per axis in the
   axis's input unit.
2. Where it fails: the residual by operating region (``regions.py``).
3. What is missing: every candidate effect on every moving axis, scored on held-out data, greedy
   forward selection (``search.py``); candidates that pass the significance rule, best first.
4. Add it: ``add=["coulomb_friction@roll", ...]`` refits the model with those effects (their
   nonlinear parameters as the selection refined them, or for an effect not selected as the
   search found them for the effect alone, step 3) and gives the residual after, computed the
   same way;
   ``replay`` re-runs the plant the data came from (a log simulated by lcgym: the IX's plant, or a
   machine file's, its sidecar's ``plant`` record) with the feedforward of the model before and
   after and compares the tracking errors.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from .. import systems
from ..data import UNIFORM_TOLERANCE, another_machine, log_rate, regularize
from ..methods.loop import loop_feedforward
from ..metrics import norms as metric_norms
from ..physics.candidates import axis_scale
from ..physics.effects import Effect, parse_key
from ..physics.kinematics import lowpass_zero_phase, reference_kinematics
from ..physics.model import PhysicalModel
from ..physics.preprocessing import reduction_memo
from .candidates import Candidate, candidates_for
from .layout import edge_outliers, layout, repeated_runs, used_samples
from .machines import machines_with_axes
from .regions import region_masks, region_table
from .result import Diagnosis
from .rows import CandidateRow, StepRow, StepScore
from .search import Prepared, prepare, rank
from .spectra import bandwidths

DEG = math.pi / 180.0
NOISE_SHARE = 0.01  # a machine without its own noise_rms: 1 % of each axis's low-passed input RMS
KINEMATICS = {"reference": "measured", "measured": "position"}  # option -> PhysicalModel.positions
GAP_PERIODS = 0.125  # a gap bridged by interpolation: up to this share of a period of the fastest low-pass


def norms(x: np.ndarray, axes: Sequence[str], units: Sequence[str], used: np.ndarray | None = None) -> dict:
    """{axis: {MA, RMS, Inf, unit}} of a residual (R, A), over each axis's ``used`` rows (default all)."""
    out = {}
    for i, ax in enumerate(axes):
        col = x[:, i] if used is None else x[used[:, i], i]
        n = metric_norms(col[:, None]) if col.size else {"MA": [0.0], "RMS": [0.0], "Inf": [0.0]}
        out[ax] = {**{k: float(v[0]) for k, v in n.items()}, "unit": units[i]}
    return out


def _check_trials(trials, system: systems.System, what: str = "trial") -> list:
    """The trials on uniform time grids (``data.regularize``: a log with jitter or dropouts, from
    Python; files are read that way), checked against the machine."""
    if not trials:
        raise ValueError("diagnose: no trials given")
    rate = log_rate(trials)
    out = []
    for k, tr in enumerate(trials):
        if tuple(tr.axes) != system.axis_names:
            hint = ""
            if another_machine(tr.axes, system.axis_names):
                which = machines_with_axes(tr.axes)
                hint = f": a log of another machine ({' or '.join(which)} has these axes)" if which else ""
            raise ValueError(f"diagnose: {what} {k} has axes {', '.join(tr.axes)}; machine {system.name} has "
                             f"{', '.join(system.axis_names)}{hint}")
        uniform = np.allclose(np.diff(tr.t), 1.0 / tr.fs, rtol=UNIFORM_TOLERANCE, atol=0.0)
        out.extend([tr] if uniform else regularize(tr, rate, max_gap=bridged_gap(), where=f"{what} {k}"))
    for k, tr in enumerate(out):
        if abs(tr.fs - out[0].fs) > 1e-6 * out[0].fs:
            raise ValueError(f"diagnose: {what} {k} is sampled at {tr.fs:g} Hz, {what} 0 at {out[0].fs:g} Hz")
    return out


def bridged_gap(filter_hz: float = PhysicalModel.filter_hz) -> float:
    """The longest gap [s] in a log that the diagnosis bridges by interpolation (``data.regularize``;
    longer ones split the trial): ``GAP_PERIODS`` of a period of its fastest low-pass, the
    kinematics' at twice the fit's corner ``filter_hz`` (12.5 ms at 5 Hz)."""
    return GAP_PERIODS / (2.0 * filter_hz)


@dataclass(frozen=True)
class DiagnoseOptions:
    """How ``diagnose`` searches, checked where it is made.

    min_explained, min_rms [input unit]: the significance rule (``search.py``); ``min_rms``
    defaults to the machine's ``noise_rms``, else to ``NOISE_SHARE`` of each axis's low-passed
    input RMS (an effect that changes the input by less is no matter for a feedforward).
    kinematics: "reference" (the reference corrected by the measured error; a trial without a
    reference uses its measured position) or "measured" (the measured position, low-passed and
    differentiated). max_steps: most effects selected (default two per moving axis).
    block_seconds: the held-out blocks' length [s] (default from the data, ``layout.py``). add:
    effects (``name@axis`` or ``Effect`` objects) to add after the search. replay: re-run the
    plant recorded in the trials' metadata.
    """

    min_explained: float = 0.1
    min_rms: float | None = None
    kinematics: str = "reference"
    max_steps: int | None = None
    block_seconds: float | None = None
    add: tuple = ()
    replay: bool = False

    def __post_init__(self):
        object.__setattr__(self, "add", tuple(self.add))
        if not 0.0 < self.min_explained < 1.0:
            raise ValueError(f"min_explained must be in (0, 1), got {self.min_explained}")
        if self.kinematics not in KINEMATICS:
            raise ValueError(f"kinematics must be 'reference' or 'measured', got {self.kinematics!r}")


@dataclass
class Setting:
    """What the data and the options settle before any fit (``_settle``): the machine, the trials
    (on uniform grids), the model to diagnose, the candidates and the effects to add (checked), the
    plant to replay on, the axes that move, the kinematics, the layout (samples used, held-out folds)
    and the significance rule (stricter where held-out blocks share one trajectory's quirks)."""

    system: systems.System
    spec: str | None
    options: DiagnoseOptions
    trials: list
    validate: list | None
    model: PhysicalModel
    candidates: list[Candidate]
    added: list[Effect]
    plant: object | None
    moving: list[int]
    kinematics: tuple  # ((q, qd, qdd), lengths) of the trials, as the model sees them
    corners: tuple[float, float]
    spread: object
    repeats: list
    layout: object  # layout.Layout
    min_explained: float
    max_steps: int
    strict: str  # the stricter rule, said in words ("" where the usual one holds)

    @property
    def fs(self) -> float:
        return self.trials[0].fs

    @property
    def axes(self) -> tuple[str, ...]:
        return self.system.axis_names


@dataclass
class Search:
    """What the search found (``_search``): the noise floor and the regions of the nominal model's
    residual, the ranking, the selected effects refitted with their shapes (``suggested``), the
    report's candidate and step rows, and every effect found as the report names it."""

    floor: np.ndarray
    regions: object
    groups: list
    ranking: object  # search.Ranking
    suggested: Prepared | None
    rows: list[CandidateRow]
    steps: list[StepRow]
    found: dict[str, Effect]

    @property
    def model(self) -> PhysicalModel:
        """The model with the selected effects, fitted."""
        return self.ranking.model if self.suggested is None else self.suggested.model


def diagnose(trials: Sequence, system: str | systems.System = "ix", options: DiagnoseOptions | None = None, *,
             candidates: Sequence[Candidate] | None = None, model: PhysicalModel | None = None,
             validate: Sequence | None = None, spec: str | None = None, progress: bool = False,
             **settings) -> Diagnosis:
    """Run the workflow of this module on measured ``trials`` of ``system`` (a ``systems.System`` or
    what ``systems.get`` accepts), searching as ``options`` say (``DiagnoseOptions``; or give its
    fields as keywords, ``min_explained=0.2``).

    model: the physical model to diagnose (unfitted; default the machine's nominal one).
    candidates: effects to try (default ``candidates.candidates_for(system)``), on the axes that
    move (reference range above the axis's ``min_travel``: a joint that stands still shows neither
    friction nor inertia). spec: the machine as the user named it (a URDF path, ``module:attr``)
    for the report's hints (default ``system`` when it is a name). validate: trials of another
    experiment of the same machine, not fitted: the residuals there of the model fitted here,
    before and after its effects (those of ``add``, else the selected ones), computed the same way
    (``Diagnosis.validation``). Trials whose time stamps are not uniform are put on uniform grids
    first (``data.regularize``).

    The stages, each a function of this module: ``_settle`` (every check before the work), ``_fit``
    (the nominal model, trial edges left out where they dominate), ``_search`` (regions, noise floor,
    the ranking and the selection), ``_add`` (the effects asked for, refitted), then validation on
    the other experiment and the replay on the plant, and ``_report``.
    """
    if options is not None and settings:
        raise TypeError(f"diagnose: give options or its fields as keywords, not both ({', '.join(settings)})")
    s = _settle(trials, system, options or DiagnoseOptions(**settings), candidates, model, validate, spec)
    with s.system.caching() if s.system.caching is not None else nullcontext(), reduction_memo():
        bar = tqdm(total=2, desc="diagnose", disable=not progress, leave=False)
        bar.set_postfix_str("fit nominal model")
        prep = _fit(s)
        bar.update()
        search = _search(s, prep, bar)
        bar.close()
        after = _add(s, prep, search) if s.added else None
        families = {c.name: c.family for c in s.candidates}
        families.update({c.effect: c.family for c in search.rows if c.named_as})
        shown = after.model if after is not None else search.model  # the model with the effects found or added
        ranges = fitted_ranges(shown, prep, families)
        axes, units = s.axes, s.system.input_units
        validated = None if s.validate is None else validation(s.validate, prep.model, shown, ranges, axes, units)
        replayed = None
        if s.options.replay:
            replayed = replay_tracking(s.trials, prep.model, shown, s.system, s.plant)
            replayed["after_with"] = [e.key for e in shown.effects if e.key not in {f.key for f in prep.model.effects}]
        return _report(s, prep, search, after, shown, families, ranges, validated, replayed)


def _settle(trials, system, options: DiagnoseOptions, candidates, model, validate, spec) -> Setting:
    """Every check before the work, and what the data settle (``Setting``)."""
    add, min_explained, max_steps = options.add, options.min_explained, options.max_steps
    spec = spec or (system if isinstance(system, str) else None)
    system = systems.get(system)
    trials = _check_trials(trials, system)
    fs = trials[0].fs
    if model is None:
        model = system.diagnosis_model(fs)
        if options.kinematics == "measured":
            model.positions = KINEMATICS[options.kinematics]
    cands = candidates_for(system) if candidates is None else list(candidates)
    added = [_parse_add(a, model, system, spec or system.name) for a in add]  # every check before the work
    keys = [e.key for e in added]
    if len(set(keys)) < len(keys):
        raise ValueError(f"an effect is added twice: {keys}")
    if validate is not None:
        validate = _check_trials(validate, system, "validation trial")
        if abs(validate[0].fs - trials[0].fs) > 1e-6 * trials[0].fs:
            raise ValueError(f"diagnose: the validation data are sampled at {validate[0].fs:g} Hz, the data fitted at "
                             f"{trials[0].fs:g} Hz; resample one of them (--resample)")
    plant = replay_plant(trials, system, spec or system.name) if options.replay else None  # before the work
    moving = moving_axes(trials, system)
    if not moving:
        raise ValueError("diagnose: no axis moves more than its minimum travel (1 deg, 1 mm) in the data")
    pre = model.preprocessing
    kin, lengths = pre.kinematics(trials)
    corners = (model.filter_hz, pre.velocity_filter_hz(trials))
    spread = pre.position_spread(trials)
    repeats = repeated_runs(trials, moving)
    lay = layout(trials, kin, lengths, fs, *corners, options.block_seconds, spread=spread, moving=moving,
                 repeats=repeats)
    strict = ""
    if repeats and not lay.whole_runs:  # held-out blocks of one trajectory share its quirks: fewer parameters, a higher bar
        shape_free = [c.name for c in cands if c.shape_free]
        cands = [c for c in cands if not c.shape_free]
        min_explained = min(STRICTER * min_explained, 0.5)
        max_steps = len(moving) if max_steps is None else max_steps
        strict = (f"each effect must remove {100 * min_explained:.0f}% of what its axis has left, at most "
                  f"{max_steps} effect(s), no curve of no set shape ({', '.join(shape_free) or 'none'})")
    max_steps = 2 * len(moving) if max_steps is None else max_steps
    return Setting(system, spec, options, trials, validate, model, cands, added, plant, moving, (kin, lengths),
                   corners, spread, repeats, lay, min_explained, max_steps, strict)


def _fit(s: Setting) -> Prepared:
    """The nominal model fitted; where the residual is dominated by trial edges, they are left out
    (``s.layout`` then says so) and the model fitted again."""
    kin, lengths = s.kinematics
    prep = prepare(s.trials, s.model, s.layout, s.kinematics)
    time = (prep.rows - np.concatenate([[0], np.cumsum(lengths)[:-1]])[prep.trial]) / s.fs
    trim = edge_outliers(prep.residual, prep.used, prep.trial, time, [n / s.fs for n in lengths], s.fs, s.layout.settle)
    if trim is not None:  # the residual is dominated by trial edges: leave them out, fit again
        s.layout = layout(s.trials, kin, lengths, s.fs, *s.corners, s.options.block_seconds, trim, s.spread, s.moving,
                          s.repeats)
        prep = prepare(s.trials, s.model, s.layout, s.kinematics)
    return prep


def _search(s: Setting, prep: Prepared, bar) -> Search:
    """The regions where the nominal model fails worst, the noise floor, and the search: every
    candidate scored alone, the greedy selection, the selected effects refitted with the model's
    own shape estimator (``refit_shapes``), and the report's rows of them."""
    system, axes, units, lay = s.system, s.axes, s.system.input_units, s.layout
    fs_rows = s.fs / max(1, prep.model.decimate)
    q, qd, qdd = (k[prep.rows] for k in prep.kin)
    floor = _noise_floor(system, prep, s.options.min_rms)
    scales = [{**sc, "rest": float(v)} for sc, v in zip(axis_scales(system, prep.kin[0], prep.kin[1]),
                                                          lay.rest_speed, strict=True)]
    regions = region_table(prep.residual, region_masks(q, qd, qdd, prep.trial, fs_rows, system.axes), axes, prep.used)
    bar.update()
    bar.set_postfix_str("candidates")
    groups = proportional_groups(prep.kin[1], lay.used, s.moving)
    ranking = rank(prep, s.trials, s.candidates, axes, lay, min_explained=s.min_explained, min_rms=floor,
                   max_steps=s.max_steps, progress=bar, search_axes=s.moving, scales=scales, kinds=system.axes,
                   position_blind=[i for g in groups for i in g["axes"]])
    selected_keys = [f"{c.candidate.name}@{axes[c.axis]}" for c, _, _ in ranking.selected]
    suggested = refit_shapes(ranking.model, selected_keys, s.trials, lay, s.kinematics) if selected_keys else None

    rows = []
    alone = {(c.candidate.name, c.axis): c for c in ranking.alone}
    refined = {e.key: e for e in (ranking.model if suggested is None else suggested.model).fitted_effects}
    for k, (c, share, before) in enumerate(ranking.selected, 1):  # explained, RMS_after: the effect alone
        n = ranking.n_rows[c.axis]
        row = _candidate_row(ranking, alone.get((c.candidate.name, c.axis), c), axes, units, selected=True, step=share)
        at_step = {"step": k, "RMS_before_at_selection": math.sqrt(before / n),
                   "RMS_after_at_selection": math.sqrt(max(before * (1.0 - share), 0.0) / n)}
        named = ranking.named[k - 1]
        if named.name != c.candidate.name:  # a form of no set shape, revised from the effect the step named
            at_step.update(family=named.family, named_as=named.name)
        final = refined.get(f"{c.candidate.name}@{axes[c.axis]}")
        if final is not None:  # the nonlinear parameters as the model's estimator found them (``refit_shapes``)
            scored = row.parameters
            at_step["parameters"] = {p: float(getattr(final, p)) for p in scored}
            if at_step["parameters"] != scored:  # the shares above were scored at the grid's values
                at_step["refined_from"] = scored
        rows.append(dataclasses.replace(row, **at_step))
    picked = {(c.candidate.name, c.axis) for c, _, _ in ranking.selected}
    rest = [c for c in ranking.alone if (c.candidate.name, c.axis) not in picked and ranking.passes_alone(c)]
    for c in sorted(rest, key=lambda c: -ranking.explained(c)):
        rows.append(_candidate_row(ranking, c, axes, units, selected=False, step=None))

    steps = [_step_row(k, st, axes, ranking.n_rows) for k, st in enumerate(ranking.steps, 1)]
    found = {f"{c.candidate.name}@{axes[c.axis]}": c.candidate.build(axes[c.axis], **c.params) for c in ranking.alone}
    picked_keys = {f"{c.candidate.name}@{axes[c.axis]}" for c, _, _ in ranking.selected}
    found.update({e.key: e for e in refined.values() if e.key in picked_keys})  # as selected, then fitted
    return Search(floor, regions, groups, ranking, suggested, rows, steps, found)


def _add(s: Setting, prep: Prepared, search: Search) -> Prepared:
    """The model with the effects asked for (``--add``), refitted: one added by name is fitted as a
    ``[[model]]`` table of it would be (its shape by the model's estimator); one given with values
    keeps them."""
    add = s.options.add
    effects = [search.found.get(e.key, e) if isinstance(a, str) else e for a, e in zip(add, s.added, strict=True)]
    after_model = prep.model
    for e in effects:
        after_model = after_model.with_effect(e)
    by_name = [e.key for a, e in zip(add, effects, strict=True) if isinstance(a, str)]
    return refit_shapes(after_model, by_name, s.trials, s.layout, s.kinematics) if by_name else \
        prepare(s.trials, after_model, s.layout, s.kinematics)


def _report(s: Setting, prep: Prepared, search: Search, after: Prepared | None, shown: PhysicalModel, families: dict,
            ranges: dict, validated, replayed) -> Diagnosis:
    """The ``Diagnosis`` of the stages' results."""
    system, axes, units, fs, trials = s.system, s.axes, s.system.input_units, s.fs, s.trials
    lay, lengths = s.layout, s.kinematics[1]
    after_record = None if after is None else {
        "added": [e.key for e in s.added],
        "residual": norms(after.residual, axes, units, after.used),
        "effects": [_effect_params(e) for e in after.model.fitted_effects],
        "parameters": dict(zip(system.param_names, map(float, after.model.fitted_params.to_vector()), strict=True))}
    q, qd = (k[prep.rows] for k in prep.kin[:2])
    info = prep.model.fit_info_
    extra_series = {**({} if after is None else {"residual_after": after.residual}),
                    "effects": effect_curves(shown, prep, families)}
    return Diagnosis(system=system.name, axes=axes, unit=system.input_unit, n_samples=sum(prep.lengths), fs=fs,
                     model_effects=[*prep.model.parts(), *(e.key for e in prep.model.effects)],
                     residual=norms(prep.residual, axes, units, prep.used), regions=search.regions, candidates=search.rows,
                     min_explained=s.min_explained, min_rms=dict(zip(axes, map(float, search.floor), strict=True)),
                     model=prep.model, suggested_model=search.model,
                     series={"t": prep.rows / fs, "residual": prep.residual, "q": q, "qd": qd, "used": prep.used,
                             "ref_velocity": _velocity(trials, fs)[prep.rows], **extra_series},
                     kinematics=_kinematics_note(trials, prep.model), identified=(info["rank"], info["n_free"]),
                     displays={a.name: a.display for a in system.axes},
                     resampled=_resampled_notes(trials, s.validate), spec=s.spec, steps=search.steps,
                     stop=search.ranking.stop,
                     options="--kinematics measured" if s.options.kinematics == "measured" else "",
                     samples={**_samples_record(lay, axes, system.axes, trials, fs),
                              "bandwidth": {k: dict(zip(axes, map(float, bandwidths(x, lengths, fs)), strict=True))
                                            for k, x in (("input", np.concatenate([tr.u for tr in trials])),
                                                         ("position", np.concatenate([tr.pos for tr in trials])))},
                              "proportional": [{"axes": [axes[i] for i in g["axes"]], "alike": g["alike"]}
                                               for g in search.groups],
                              "repeated": s.repeats, "strict": s.strict},
                     blocks=_blocks_note(lay),
                     machine_file=_machine_file(system), found=search.found, after=after_record,
                     after_model=None if after is None else after.model, ranges=ranges, validation=validated,
                     replay=replayed)


def refit_shapes(model: PhysicalModel, keys: Sequence[str], trials: Sequence, lay, kinematics) -> Prepared:
    """``model`` fitted again (``prepare``) with the nonlinear parameters of its effects ``keys``
    found by the physical model's own estimator (``physics.shapes``): the one a machine file's
    ``[[model]]`` table of them is fitted by, so that the values the report prints, its replay and
    validation, and the benchmark's model with those tables come from one fit of each effect. The
    selection's search chose the effects; their shapes it tried stay in its step rows. An effect
    that estimator cannot take keeps the selection's shape."""
    from ..physics.shapes import model_candidate

    def fits(key: str) -> bool:
        try:
            model_candidate(model.system, key, type(model).built_in)
        except ValueError:
            return False
        return True

    ours = tuple(k for k in keys if fits(k))
    search = (*model.search_shapes, *(k for k in ours if k not in model.search_shapes))
    return prepare(trials, dataclasses.replace(model, search_shapes=search), lay, kinematics)


VARIABLES = ("position", "velocity", "acceleration")


def acts_on(family: str) -> int:
    """The kinematic variable (index into ``VARIABLES``) an effect of ``family`` is a curve over:
    a friction over the velocity, an inertia over the acceleration, the others over the position."""
    return {"friction": 1, "inertia": 2}.get(family, 0)


def effect_curves(model: PhysicalModel, prep, families: dict) -> list[dict]:
    """Per effect of ``model`` beyond those of the nominal model ``prep.model``: its fitted torque
    at the reduced rows over the variable it acts on (``Diagnosis.plot``'s effects.png)."""
    start = {e.key for e in prep.model.effects}
    kin = tuple(k[prep.rows] for k in prep.kin)
    loads = model.load_torques(kin)
    out = []
    for e in model.fitted_effects:
        if e.key in start:
            continue
        family = families.get(e.name, "user")
        which = acts_on(family)
        out.append({"effect": e.key, "family": family, "variable": VARIABLES[which],
                    "x": kin[which][:, e.index], "torque": e.torque(*kin, loads)[:, e.index], "used": prep.used[:, e.index]})
    return out


def fitted_ranges(model: PhysicalModel, prep, families: dict) -> dict:
    """{key: {"variable", "lo", "hi"}} per effect of ``model`` beyond those of the nominal model
    ``prep.model`` (an offset, constant, has none): the range of the variable it acts on
    (``acts_on``) over the samples of its axis the fit used [rad, rad/s, rad/s^2 or m, m/s, m/s^2].
    Outside it the effect is extrapolated (``Diagnosis.validation`` says where other data go)."""
    start = {e.key for e in prep.model.effects}
    out = {}
    for e in model.fitted_effects:
        family = families.get(e.name, "user")
        if e.key in start or family == "offset":
            continue
        which = acts_on(family)
        x = prep.kin[which][prep.rows, e.index][prep.used[:, e.index]]
        if x.size:
            out[e.key] = {"variable": VARIABLES[which], "lo": float(x.min()), "hi": float(x.max())}
    return out


def outside_ranges(ranges: dict, kin, rows: np.ndarray, used: np.ndarray, axes: Sequence[str]) -> list[dict]:
    """Where data (kinematics ``kin`` (q, qd, qdd) (T, A), their reduced ``rows`` and the ``used``
    mask of those (R, A)) leave the fitted ``ranges`` (``fitted_ranges``): per effect that has samples
    outside, the extremes reached ("min", "max") and the share of the axis's used samples outside."""
    out = []
    for key, r in ranges.items():
        i = list(axes).index(key.partition("@")[2])
        x = kin[VARIABLES.index(r["variable"])][rows, i][used[:, i]]
        beyond = (x < r["lo"]) | (x > r["hi"])
        if x.size and beyond.any():
            out.append({"effect": key, **r, "min": float(x.min()), "max": float(x.max()),
                        "share": float(beyond.mean())})
    return out


def _samples_record(lay, axes, kinds, trials, fs) -> dict:
    """What the layout left out, per axis, for the report (``Diagnosis.samples``)."""
    total = lay.counts["samples"]
    return {"total": total, "trials": len(trials), "edges": lay.counts["edges"], "edges_trimmed": lay.counts["edge_trimmed"],
            "settle_s": lay.settle,
            "standstill": {ax: int(n) for ax, n in zip(axes, lay.counts["standstill"], strict=True)},
            "rest_speed": {ax: float(v) for ax, v in zip(axes, lay.rest_speed, strict=True)},
            "used": {ax: int(n) for ax, n in zip(axes, lay.used.sum(axis=0), strict=True)}}


def _blocks_note(lay) -> str:
    """How the held-out folds were made, in one line (``layout.layout``)."""
    if lay.whole_runs:
        folds = [", ".join(str(k) for k, f in enumerate(lay.first) if f == fold) for fold in (0, 1)]
        return f"whole runs as the two folds (trials {folds[0]} | {folds[1]}): runs of different motions"
    lengths = sorted(set(round(b, 2) for b in lay.blocks))
    what = f"{lengths[0]:g} s" if len(lengths) == 1 else f"{lengths[0]:g}-{lengths[-1]:g} s"
    return (f"held-out blocks of {what}, alternating between two folds within each trial"
            + (f" ({lay.why_not})" if lay.why_not else ""))


STRICTER = 2.0
"""Where runs repeat one trajectory (``layout.repeated_runs``), ``min_explained`` is this many times
higher, at most one effect per moving axis is selected and no curve of no set shape is tried."""
PROPORTIONAL = 0.99
"""Axes whose velocities are this alike over the data (|cosine| of the two velocity series) move in
proportion (``proportional_groups``): less than 14 % of either's motion is its own."""


def proportional_groups(qd: np.ndarray, used: np.ndarray, moving: Sequence[int], alike: float = PROPORTIONAL
                        ) -> list[dict]:
    """Groups of moving axes that move (nearly) in proportion over the samples both use: {"axes":
    indices, "alike": the least |cosine| between the velocities (T, A) of two linked axes}. An effect
    over the position of one such axis could as well follow another's: the data cannot attribute it."""
    parent = {i: i for i in moving}

    def root(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    least = {}
    for k, i in enumerate(moving):
        for j in moving[k + 1:]:
            both = used[:, i] & used[:, j]
            a, b = qd[both, i], qd[both, j]
            norm = math.sqrt(float(a @ a) * float(b @ b))
            cos = abs(float(a @ b)) / norm if norm > 0 else 0.0
            if cos >= alike:
                parent[root(j)] = root(i)
                least[(i, j)] = cos
    groups: dict[int, list[int]] = {}
    for i in moving:
        groups.setdefault(root(i), []).append(i)
    return [{"axes": g, "alike": min(c for (i, j), c in least.items() if i in g and j in g)}
            for g in groups.values() if len(g) > 1]


def moving_axes(trials: Sequence, system: systems.System) -> list[int]:
    """Indices of the axes whose reference (or, without one, measured position) travels at least the
    axis's ``min_travel`` within the trials: the sum of each trial's span (an axis held at another
    place in each run does not move; a run split at its gaps still does)."""
    span = np.sum([np.ptp(tr.ref if tr.ref is not None else tr.pos, axis=0) for tr in trials], axis=0)
    return [i for i, a in enumerate(system.axes) if span[i] >= a.min_travel]


def axis_scales(system: systems.System, q: np.ndarray, qd: np.ndarray) -> list[dict]:
    """Per axis the {"speed", "position"} scales of the candidates' grids (``physics.candidates.axis_scale``)."""
    return [axis_scale(a, q[:, i], qd[:, i]) for i, a in enumerate(system.axes)]


def _noise_floor(system: systems.System, prep, min_rms: float | None) -> np.ndarray:
    """min_rms per axis: given, the machine's noise_rms, or NOISE_SHARE of the low-passed input's RMS."""
    if min_rms is not None:
        return np.full(system.n_axes, float(min_rms))
    if system.diagnosis.noise_rms is not None:
        return np.full(system.n_axes, float(system.diagnosis.noise_rms))
    return NOISE_SHARE * np.sqrt((prep.u**2).sum(axis=0) / np.maximum(prep.n_used, 1))


def _velocity(trials, fs) -> np.ndarray:
    """Reference velocity (or, without a reference, the low-passed measured one), all trials (T, A)."""
    return np.concatenate([reference_kinematics(tr.ref if tr.ref is not None else lowpass_zero_phase(tr.pos, fs, 5.0),
                                                fs)[1] for tr in trials])


def _kinematics_note(trials, model: PhysicalModel) -> str:
    if model.positions == "position" or all(tr.ref is None for tr in trials):
        return (f"measured position, {model.preprocessing.kinematics_filter_hz:g} Hz zero-phase low-pass, then differentiated"
                + (" (the data have no reference)" if model.positions != "position" else ""))
    if model.positions == "measured":
        return "reference corrected by the measured tracking error (low-passed), differentiated"
    return "reference, differentiated"


def _resampled_notes(trials, validate) -> str | None:
    """What ``data.regularize`` did to the data and to the validation log, in one line (None: nothing)."""
    notes = [_resampled_note(trials)]
    if validate is not None and (note := _resampled_note(validate)):
        notes.append(f"the validation log, read as the data: {note}")
    return "; ".join(n for n in notes if n) or None


def _resampled_note(trials) -> str | None:
    """What ``data.regularize`` did to the log, in one line (None: nothing)."""
    done = [tr.meta["resampled"] for tr in trials if isinstance(tr.meta.get("resampled"), dict)]
    done = [d for d in done if d.get("segment", 0) == 0]  # one note per trial of the log, not per segment
    if not done:
        return None
    step = float(np.mean([d["log_step"] for d in done]))
    text = (f"{len(done)} trial(s) with non-uniform time stamps resampled to {done[0]['fs']:g} Hz by linear "
            f"interpolation (the log's mean step {1e3 * step:.4g} ms)")
    bridged = sum(d.get("gaps_bridged", 0) for d in done)
    if bridged:
        text += f"; {bridged} gap(s) bridged (the largest {1e3 * max(d['largest_bridged'] for d in done):.4g} ms)"
    splits = sum(d.get("splits", 0) for d in done)
    if splits:
        text += (f"; split at {splits} gap(s) too long to bridge (the largest {1e3 * max(d['largest_split'] for d in done):.4g}"
                 f" ms; at most {1e3 * bridged_gap():.3g} ms are bridged)")
    dropped = sum(tr.meta["resampled"].get("short_segments_left_out", 0) for tr in trials
                  if isinstance(tr.meta.get("resampled"), dict) and tr.meta["resampled"].get("segment", 0) == 0)
    if dropped:
        text += f"; {dropped} segment(s) between gaps too short to use left out"
    return text


def _parse_add(item, model: PhysicalModel, system: systems.System, spec: str) -> Effect:
    """An effect to add, bound to the machine: an Effect, or a ``name@axis`` label of a candidate
    (``spec``: the machine as the user named it, for the hint)."""
    if isinstance(item, Effect):
        return system.effect(item)
    name, axis = parse_key(item)
    if name in model.parts():
        raise ValueError(f"cannot add {item}: the model already has {name}")
    if item in system.model_effects:
        raise ValueError(f"cannot add {item}: the model already has it (one of {system.name}'s model effects, a "
                         "machine file's [[model]] tables)")
    available = [c.name for c in candidates_for(system)]
    if name not in available:
        raise ValueError(f"cannot add {item}: {name!r} is not an effect diagnose can add on {system.name}; choose from "
                         f"{', '.join(available)} (`lcgym effects --system {spec}`)")
    return system.effect(item)


def _effect_params(e: Effect) -> dict:
    return {"effect": e.key, **{n: float(getattr(e, n)) for n in (*e.linear, *e.nonlinear)}}


def _candidate_row(ranking, s, axes, units, selected: bool, step: float | None) -> CandidateRow:
    cand = s.candidate
    n = ranking.n_rows[s.axis]
    return CandidateRow(effect=cand.name, axis=axes[s.axis], family=cand.family, explained=ranking.explained(s),
                        RMS_before=math.sqrt(ranking.baseline[s.axis] / n), RMS_after=math.sqrt(s.held_out_sse / n),
                        unit=units[s.axis], selected=selected, explained_at_selection=step,
                        parameters={k: float(v) for k, v in s.params.items()})


def validation(trials: Sequence, model: PhysicalModel, after_model: PhysicalModel, ranges: dict, axes, units) -> dict:
    """Residual norms on ``trials`` (not fitted) of the fitted nominal ``model`` and of ``after_model``
    (the model with the effects added, else refitted with the selected ones), and where those
    trials leave the effects' fitted ranges (``ranges``, ``outside_ranges``)."""
    added = [e.key for e in after_model.effects if e.key not in {f.key for f in model.effects}]
    pre = model.preprocessing
    kin, lengths = pre.kinematics(trials)
    mask = used_samples(trials, kin, lengths, model.fs, model.filter_hz, pre.velocity_filter_hz(trials),
                        spread=pre.position_spread(trials))[0]  # standstill and trial edges left out, as fitted
    rows = pre.reduced_rows(lengths)
    used = mask[rows]
    ranges = {k: r for k, r in ranges.items() if k in added}
    return {"trials": len(trials), "n_samples": int(sum(tr.n_samples for tr in trials)), "added": added,
            "residual": norms(model.residual(trials, mask), axes, units, used),
            "residual_after": norms(after_model.residual(trials, mask), axes, units, used),
            "outside": outside_ranges(ranges, kin, rows, used, axes)}


def _step_row(k: int, step, axes, n_rows: np.ndarray) -> StepRow:
    """One greedy step for the report (``rows.StepRow``): each axis's held-out RMS left, and every
    candidate scored then, the most removed first (``rows.StepScore``)."""
    scores = []
    for s, removed, why in sorted(step.scores, key=lambda x: -x[1]):
        a = s.axis
        scores.append(StepScore(effect=s.candidate.name, axis=axes[a], removed_RMS=math.sqrt(max(removed, 0.0) / n_rows[a]),
                                share_of_left=max(removed, 0.0) / step.left[a] if step.left[a] > 0 else 0.0,
                                share_of_original=max(removed, 0.0) / step.original[a] if step.original[a] > 0 else 0.0,
                                verdict=why))
    picked = None if step.picked is None else f"{step.picked.candidate.name}@{axes[step.picked.axis]}"
    return StepRow(step=k, left_RMS={ax: math.sqrt(float(step.left[i]) / n_rows[i]) for i, ax in enumerate(axes)},
                   picked=picked, revised=list(step.revised), replacements=list(step.replacements), candidates=scores)


def _machine_file(system: systems.System) -> str | None:
    """The machine file a machine's plant settings came from, if any."""
    settings = None if system.bench is None else system.bench.settings
    return None if settings is None else settings.source


def replay_plant(trials: Sequence, system: systems.System, spec: str | None = None):
    """The plant recorded in the trials' metadata (``meta["plant"]``: a measurement file's sidecar),
    rebuilt by the machine's bench (``Bench.plant_from_record``: the IX's from the record,
    a machine file's from the file, checked against the record). ``spec``: the machine as the user
    named it, for the messages."""
    spec = spec or system.name
    record = trials[0].meta.get("plant")
    if not isinstance(record, dict):
        raise ValueError(f"--replay needs a log of a plant simulated by lcgym (lcgym simulate --system {spec} --out "
                         "FILE): the file's sidecar has no 'plant' record")
    if system.bench is None or not system.bench.replays:
        named = record.get("machine_file")
        raise ValueError(f"--replay: machine {system.name} cannot rebuild a plant from a record (the IX and machine "
                         "files can)" + (f"; the log was simulated on machine file {named}: --system {named}"
                                         if named else ""))
    if record.get("system") not in (None, system.name):
        raise ValueError(f"--replay: the log was simulated on machine {record['system']!r}, not on {system.name}")
    try:
        return system.make_bench().plant_from_record(record)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"--replay: {exc}") from None


def replay_tracking(trials: Sequence, before: PhysicalModel, after: PhysicalModel,
                    system: systems.System | None = None, plant=None) -> dict:
    """Re-run the plant recorded in the trials' metadata (``replay_plant``; or ``plant``) on their
    references with the feedforward of ``before`` and of ``after`` (each with what the loop needs to
    track exactly, as the benchmark's physical base has it: ``methods.loop.loop_feedforward``);
    tracking-error RMS per axis in the axes' display unit (deg, mm)."""
    system = before.system if system is None else system
    plant = replay_plant(trials, system) if plant is None else plant
    refs = [tr.ref for tr in trials]
    out = {}
    for label, m in (("before", before), ("after", after)):
        runs = plant.run(refs, [m.predict(r) + loop_feedforward(plant, r) for r in refs])
        e = np.concatenate([r.error for r in runs])
        out[label] = {a.name: float(a.display[0] * np.sqrt(np.mean(e[:, i] ** 2))) for i, a in enumerate(system.axes)}
    out["unit"] = {a.name: a.display[1] for a in system.axes}
    return out
