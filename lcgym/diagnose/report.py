"""The diagnosis's printed report (``text``) of a ``result.Diagnosis``."""

from __future__ import annotations

import math
from pathlib import Path

NOTHING_FOUND = "no missing effect found"
MAX_PRINTED_PARAMETERS = 8  # a machine with more (a URDF's 10 per link) has its fitted parameters in the JSON only


def text(d, n_regions: int = 4, n_shown: int = 3) -> str:
    """The printed report of ``d``, a ``result.Diagnosis`` (``n_shown``: candidates per selection
    step, besides those that pass)."""
    unit = {ax: r["unit"] for ax, r in d.residual.items()}
    one_unit = len(set(unit.values())) == 1
    head = f" [{d.unit}]" if one_unit else ""
    col = "" if one_unit else " unit"
    w = max(12, *(len(ax) for ax in d.axes))  # the axis column, as wide as the longest joint name
    lines = [f"lcgym diagnose: system {d.system}, {d.n_samples} samples at {d.fs:g} Hz",
             f"model: {', '.join(d.model_effects)} (least squares; residual = u - f after a 5 Hz zero-phase low-pass)",
             f"kinematics: {d.kinematics}" if d.kinematics else None,
             f"data: {d.resampled}" if d.resampled else None,
             *_samples_lines(d, w),
             f"held-out scoring: {d.blocks}" if d.blocks else None,
             (f"identified: {d.identified[0]} combinations of the model's {d.identified[1]} free parameters "
              "(the rest keep their nominal values)") if d.identified and d.identified[0] < d.identified[1]
             else None,
             "", f"residual{head} (floor: the least RMS an effect must remove to count, the noise floor):",
             f"  {'axis':{w}s} {'MA':>9s} {'RMS':>9s} {'Inf':>9s} {'floor':>9s}{col}"]
    lines = [x for x in lines if x is not None]
    for ax in d.axes:
        r = d.residual[ax]
        lines.append(f"  {ax:{w}s} {_num(r['MA'])} {_num(r['RMS'])} {_num(r['Inf'])} {_num(d.min_rms[ax])}"
                     + ("" if one_unit else f" {r['unit']}"))
    lines += ["", "where the model fails worst (residual RMS there / overall):"]
    for ax in d.axes:
        for reg in [r for r in d.regions if r.axis == ax][:n_regions]:
            lines.append(f"  {ax:{w}s} {reg.where:44s} RMS {reg.RMS:.4g} {unit[ax]} ({reg.ratio:.2f}x, "
                         f"{100 * reg.samples:.0f}% of samples)")
    lines += ["", "candidate missing effects (share of the axis's residual energy each removes alone on held-out"
              " data; selected ones in the order of greedy forward selection):"]
    if not d.candidates:
        lines.append(f"  {NOTHING_FOUND} (none removes {100 * d.min_explained:.0f}% of its axis's residual with at "
                     "least the axis's floor)")
    for k, c in enumerate(d.candidates, 1):
        how = (f"selected at step {c.step}: {100 * c.explained_at_selection:.0f}% of what was left, "
               f"{c.RMS_before_at_selection:.4g} -> {c.RMS_after_at_selection:.4g} {c.unit}"
               if c.selected else "not needed once the selected ones are in")
        if c.named_as:
            how += f"; named {c.named_as}@{c.axis}, then its shape refined by this curve of no set shape"
        display = d.displays.get(c.axis, (180 / math.pi, "deg"))
        params = ", ".join(f"{n}={_fmt(n, v, display)}" for n, v in c.parameters.items())
        if c.refined_from:
            params += " (refined from " + ", ".join(f"{n}={_fmt(n, v, display)}"
                                                    for n, v in c.refined_from.items()) + ")"
        fitted = range_text(d, c.key) if c.selected else ""
        lines.append(f"  {k}. {c.key} [{c.family}]: {100 * c.explained:.0f}%, "
                     f"held-out RMS {c.RMS_before:.4g} -> {c.RMS_after:.4g} {c.unit} "
                     f"({how}{'; ' + params if params else ''}{'; fitted over ' + fitted if fitted else ''})")
    if d.candidates:
        lines.append(f"  add the selected ones: lcgym diagnose DATA --system {d.spec or d.system} "
                     + (f"{d.options} " if d.options else "") + " ".join(f"--add {m}" for m in d.missing))
    refused = d.refused()
    if refused:
        lines += ["", f"refused (removed at least {100 * d.min_explained:.0f}% of what its axis had left at some "
                  "step, but failed another rule of the significance test):"]
        wr = max(len(c.key) for c in refused)
        for c in refused:
            lines.append(f"  {c.key:{wr}s}  step {c.step}: {100 * c.share_of_left:3.0f}% "
                         f"of what was left, {100 * c.share_of_original:3.0f}% of the original: {c.verdict}")
    if d.steps:
        lines += ["", "selection step by step (held-out RMS each axis had left; the candidates that removed most of it, "
                  "share of what was left / of the original error; all of them in the JSON):"]
        for st in d.steps:
            left = ", ".join(f"{ax} {v:.4g}" + ("" if one_unit else f" {unit[ax]}") for ax, v in st.left_RMS.items())
            revised = "".join(f"; then {r}" for r in st.revised)
            lines.append(f"  step {st.step}: left {left}{head}" + (f" -> add {st.picked}" if st.picked else "")
                         + revised)
            shown = st.candidates[:n_shown]
            shown += [c for c in st.candidates[n_shown:] if c.verdict == "passes"]
            ws = max([34] + [len(c.key) for c in shown])
            for c in shown:
                lines.append(f"    {c.key:{ws}s} {100 * c.share_of_left:4.0f}% / "
                             f"{100 * c.share_of_original:4.0f}%  {c.verdict}")
            lines += [f"    tried {r}" for r in st.replacements]
        lines.append(f"  stopped: {d.stop}")
    if d.after is not None:
        lines += ["", f"after adding {', '.join(d.after['added'])} and refitting, residual RMS{head}:",
                  f"  {'axis':{w}s} {'before':>9s} {'after':>9s} {'change':>8s}"]
        for ax in d.axes:
            b, a = d.residual[ax]["RMS"], d.after["residual"][ax]["RMS"]
            change = f"{100 * (a - b) / b:+7.0f}%" if b > 0 else "       -"
            lines.append(f"  {ax:{w}s} {_num(b)} {_num(a)} {change}" + ("" if one_unit else f" {unit[ax]}"))
        params = d.after.get("parameters", {})
        if 0 < len(params) <= MAX_PRINTED_PARAMETERS:
            lines.append("  fitted parameters: " + ", ".join(f"{n} {v:.4g}" for n, v in params.items()))
        for e in d.after["effects"]:
            display = d.displays.get(e["effect"].partition("@")[2], (180 / math.pi, "deg"))
            fitted = range_text(d, e["effect"])
            lines.append(f"  fitted {e['effect']}: " + ", ".join(f"{n} {_fmt(n, v, display)}" for n, v in e.items()
                                                              if n != "effect")
                         + (f" (over {fitted})" if fitted else ""))
    if d.validation is not None:
        v = d.validation
        what = f"with {', '.join(v['added'])}" if v["added"] else "with no effect added (none selected)"
        lines += ["", f"validation on {v['n_samples']} samples of other data, not fitted (the model as fitted "
                  f"above, before and {what}), residual RMS{head}:",
                  f"  {'axis':{w}s} {'before':>9s} {'after':>9s} {'change':>8s}"]
        for ax in d.axes:
            b, a = v["residual"][ax]["RMS"], v["residual_after"][ax]["RMS"]
            change = f"{100 * (a - b) / b:+7.0f}%" if b > 0 else "       -"
            lines.append(f"  {ax:{w}s} {_num(b)} {_num(a)} {change}" + ("" if one_unit else f" {unit[ax]}"))
        outside = v.get("outside", [])
        if v["added"]:
            lines.append("  outside the effects' fitted ranges (extrapolated there):" if outside else
                         "  every sample within the effects' fitted ranges")
        for o in outside:
            display = d.displays.get(o["effect"].partition("@")[2], (180 / math.pi, "deg"))
            reach = [_in_unit(x, o["variable"], display) for x in (o["min"], o["max"])]
            lines.append(f"    {o['effect']}: {o['variable']} {reach[0]} .. {reach[1]} (fitted over "
                         f"{range_text(d, o['effect'])}), {100 * o['share']:.1f}% of the samples outside")
    if d.replay is not None:
        replay_unit = d.replay["unit"]
        same = len(set(replay_unit.values())) == 1
        added = d.replay.get("after_with", [])
        lines += ["", "replay on the plant, tracking-error RMS" + (f" [{next(iter(replay_unit.values()))}]" if same else "")
                  + " with the model's feedforward, before and " + (f"with {', '.join(added)}" if added else
                                                                     "after (no effect added)") + ":",
                  f"  {'axis':{w}s} {'before':>9s} {'after':>9s}"]
        for ax in d.axes:
            lines.append(f"  {ax:{w}s} {_num(d.replay['before'][ax])} {_num(d.replay['after'][ax])}"
                         + ("" if same else f" {replay_unit[ax]}"))
    lines += _model_tables_lines(d)
    return "\n".join(lines)



def range_text(d, key: str) -> str:
    """The fitted range of effect ``key`` in the axis's display unit ("velocity -28.1 .. 28.4
    deg/s"), or "" where it has none."""
    r = d.ranges.get(key)
    if r is None:
        return ""
    display = d.displays.get(key.partition("@")[2], (180 / math.pi, "deg"))
    lo, hi = (_in_unit(x, r["variable"], display) for x in (r["lo"], r["hi"]))
    return f"{r['variable']} {lo} .. {hi}"



def _samples_lines(d, w: int) -> list[str]:
    """What was fitted and what was left out (``samples``), for ``text``."""
    s = d.samples
    if not s:
        return []
    total, still = s["total"], s["standstill"]
    trimmed = (f", and {s['edges_trimmed']} more where the residual was dominated by trial edges (an unsettled start "
               "or a move cut off)") if s["edges_trimmed"] else ""
    out = [f"samples: {total} in {s['trials']} trial(s); left out on every axis: {s['edges']} at trial edges "
           f"(the filters' first and last {s['settle_s']:.2g} s{trimmed})"]
    if any(still.values()):
        speed = {ax: _fmt("eps", v, d.displays.get(ax, (180 / math.pi, "deg"))) for ax, v in s["rest_speed"].items()}
        rest = ", ".join(f"{ax} {100 * n / total:.0f}% (below {speed[ax]})" for ax, n in still.items() if n)
        out.append(f"standstill left out of its axis's fit and score: {rest}")
    for g in s.get("repeated", []):
        trials = ", ".join(str(k) for k in g)
        out.append(f"repeated: trials {trials} repeat one trajectory; held-out blocks of one trajectory cannot tell "
                   f"a missing effect from its own quirks, so the selection is stricter: {s['strict']}"
                   if s.get("strict") else
                   f"repeated: trials {trials} repeat one trajectory; they share a fold, so that what is held out is "
                   "another motion")
    band = s.get("bandwidth")
    if band:
        out.append("bandwidth (99.9% of the energy below) [Hz]: input " + ", ".join(
            f"{ax} {f:.3g}" for ax, f in band["input"].items()) + "; position " + ", ".join(
            f"{ax} {f:.3g}" for ax, f in band["position"].items())
            + " (a candidate whose torque lies mostly where the input holds less is refused)")
    for g in s.get("proportional", []):
        out.append(f"moving in proportion: {', '.join(g['axes'])} (velocities alike to {g['alike']:.4f}): no effect "
                   "over the position is tried there, as the data cannot tell whose position it follows; a motion "
                   "that moves them independently would tell them apart")
    return out



def _model_tables_lines(d) -> list[str]:
    """The printed report's last part: ``model_tables`` with where they go."""
    tables = d.model_tables()
    if not tables:
        return []
    which = "added" if d.after is not None else "selected"
    package = Path(__file__).resolve().parents[1]
    if Path(d.machine_file).resolve().is_relative_to(package):  # a built-in machine's: the user's copy takes them
        where = (f"{d.system}'s machine file is lcgym's own ({d.machine_file}): paste them into a copy of its "
                 "folder and bench that (docs/own-machine-bench.md)")
    else:
        where = f"paste them into {d.spec if str(d.spec).lower().endswith('.toml') else d.machine_file}"
    return ["", f"[[model]] tables of the effects {which}: {where}; the physical model then fits their parameters "
            "and every method starts from it (docs/own-machine.md):", tables]



def _num(x: float) -> str:
    """A residual figure in a 9-wide column: 4 significant digits, whatever its size."""
    return f"{x:9.4g}" if x != 0 else f"{0:9d}"


def _in_unit(value: float, variable: str, display: tuple[float, str]) -> str:
    """A position, velocity or acceleration [rad or m, per s, per s^2] in the axis's display unit."""
    f, unit = display
    return f"{value * f:.3g} {unit}" + {"position": "", "velocity": "/s", "acceleration": "/s^2"}[variable]


def _fmt(name: str, value: float, display: tuple[float, str] = (180 / math.pi, "deg")) -> str:
    """Nonlinear parameters in readable units: positions and speeds in the axis's display unit
    (``display`` = (factor, unit): deg and deg/s, or mm and mm/s)."""
    f, unit = display
    if name in ("q0", "width", "period", "lo", "hi"):
        return f"{value * f:.3g} {unit}"
    if name in ("eps", "vs", "v_ref", "v_top"):
        return f"{value * f:.3g} {unit}/s"
    return f"{value:.3g}"
