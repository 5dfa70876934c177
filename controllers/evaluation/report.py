"""The one-page Markdown report of a comparison (``report.md``) and its printed recommendations.

Sections: what was run; which law per task and mode (:func:`verdict`: the recommendation, its score
and caveats; the score's definition; with ``--params``, the tasks' holds beyond that rig's reach); per mode the tracking table and the command table, every number a
median over episodes with its 95 % interval and every header with its unit; per task the history of one
episode beside the distributions over all episodes (:mod:`controllers.evaluation.figures`); the designed
laws' loop margins; skipped laws.
"""

from __future__ import annotations

import functools
import math
import time
from pathlib import Path
from typing import Any, Callable, TextIO

from controllers.evaluation import figures
from controllers.evaluation.summary import BY_KEY, Comparison, table_cells

__all__ = ["verdict", "write"]


def verdict(cmp: Comparison, markdown: bool = False) -> list[str]:
    """One line per task and mode (the recommended law, or "tie" / "none") followed by its caveats."""
    out = ["## Which law", "", f"Rule: {cmp.rule.describe()}.", ""] if markdown else [f"which law ({cmp.rule.describe()})"]
    for task, modes in cmp.recommendations.items():
        for mode, rec in modes.items():
            if rec["law"] is not None:
                lo, hi = rec["score_ci95"]
                head = f"{rec['law']} (score {rec['score']:.2f} [{lo:.2f}, {hi:.2f}])"
            elif rec["tied"]:
                head = "tie: " + ", ".join(rec["tied"])
            else:
                head = "no law meets the criterion"
            head = f"**{head}**" if markdown else head
            out.append(f"- {task}, {mode}: {head}")
            out += [f"    - {c}" if markdown else f"    {c}" for c in rec["caveats"]]
    beyond = [line for lines in cmp.settings.get("reach", {}).values() for line in lines]
    if beyond:  # rig compare --params: draws this rig cannot hold (controllers.evaluation.reach)
        params = cmp.settings.get("params_file")
        if markdown:
            out += ["", "### Beyond this rig's reach", "", f"The tasks' draws were chosen for the default rig; on `{params}` these holds need more "
                    "of the compensator's travel than the task allows (`controllers.evaluation.reach`), and the episodes that ask for "
                    "them fail whatever the law:", ""]
        else:
            out.append(f"beyond this rig's reach ({params}: the tasks' draws were chosen for the default rig)")
        out += [f"- {line}" if markdown else f"    {line}" for line in beyond]
    return out


def _md_tables(rows: list[dict[str, Any]]) -> list[str]:
    out = []
    for task in dict.fromkeys(r["task"] for r in rows):
        rs = [r for r in rows if r["task"] == task]
        out += [f"**{task}**", ""]
        for which in ("tracking", "command"):
            head, body = table_cells(rs, which)
            out += ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
            out += ["| " + " | ".join(b) + " |" for b in body]
            out.append("")
    return out


def _f(x: Any) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return f"{v:.1f}" if math.isfinite(v) else "-"


def _margins_md(margins: dict[str, dict[str, Any]]) -> str:
    lines = ["| task | law | loop | gain margin, dB | phase margin, deg | crossover, rad/s |", "|---|---|---|---:|---:|---:|"]
    for task, laws in margins.items():
        for law, d in laws.items():
            if law == "pid":
                for j, t in d.items():
                    at = f"V {float(t['airspeed']):g} m/s, phi 0 deg"
                    lines.append(f"| {task} | pid | {j} rate (inner), {at} | {_f(t['gm_inner'])} | {_f(t['pm_inner'])} | {_f(t['wc_inner'])} |")
                    lines.append(f"| {task} | pid | {j} angle (outer), {at} | {_f(t['gm_outer'])} | {_f(t['pm_outer'])} | {_f(t['wc_outer'])} |")
            elif law == "lqr":
                for point in d.get("points", []):
                    for j, m in point.items():
                        if isinstance(m, dict):
                            axis = {"rig_roll": "roll (aileron)", "rig_pitch": "heave", "rig_yaw": "sway"}.get(j, j)
                            lines.append(f"| {task} | lqr | {axis} input, V {point['airspeed']:g} m/s, phi {point['phi_deg']:g} deg | "
                                         f"{_f(m['gm_db'])} | {_f(m['pm_deg'])} | {_f(m['wc'])} |")
    return "\n".join(lines)


def _flown(settings: dict[str, Any]) -> str:
    """Each mode's airspeed draw and gusts as flown (``[conditions]`` overrides included), and the tasks whose airspeed
    floor raised the draw: the numbers the tables were made under, not the defaults the sentence before describes."""
    parts = []
    for mode, c in settings.get("conditions", {}).items():
        a = c.get("airspeed", [math.nan, math.nan])
        parts.append(f"{mode} airspeed {float(a[0]):g}-{float(a[1]):g} m/s, {100 * float(c.get('turbulence', math.nan)):g} % gusts")
    parts += [f"{t} at {float(a[0]):g}-{float(a[1]):g} m/s (its airspeed floor)" for t, a in settings.get("airspeed", {}).items()]
    return "; ".join(parts)


def _glossary() -> list[str]:
    keys = ["rms_error", "hold_error", "rise_time", "settling_time", "overshoot_pct", "cmd_rms", "cmd_rate_rms", "saturation",
            "cmd_freq", "cmd_osc_amp", "stop_time", "emulation_error", "amplitude_ratio", "phase_lag_deg"]
    return [f"- {BY_KEY[k].header}, {BY_KEY[k].unit}: {BY_KEY[k].meaning}" for k in keys]


def write(cmp: Comparison, out: Path, progress: TextIO | None = None) -> list[Path]:
    """Write the figures and report.md into ``out``; returns the figure paths.  ``progress``: a stream told how
    many figures are written, every couple of seconds (drawing a dozen takes several)."""
    tasks = list(dict.fromkeys(r["task"] for r in cmp.rows))
    first = [r for r in cmp.results if r.conditions == cmp.settings["modes"][0]]
    jobs: list[tuple[str, Callable[[], Path]]] = [(f"history_{r.task}", functools.partial(figures.plot_history, r, out / f"history_{r.task}.png")) for r in first]
    jobs += [(f"distributions_{t}", functools.partial(figures.plot_distributions, cmp, t, out / f"distributions_{t}.png")) for t in tasks]
    jobs += [("metrics", functools.partial(figures.plot_metrics, cmp, out / "metrics.png"))]
    if progress is not None:
        progress.write(f"  drawing {len(jobs)} plots into {out} ...\n")
        progress.flush()
    files, last = [], time.perf_counter()
    for k, (_, draw) in enumerate(jobs, 1):
        files.append(draw())
        if progress is not None and time.perf_counter() - last >= 2.0 and k < len(jobs):
            last = time.perf_counter()
            progress.write(f"  plots: {k} of {len(jobs)}\n")
            progress.flush()
    named = {name: path for (name, _), path in zip(jobs, files)}
    hist = {t: named[f"history_{t}"] for t in tasks if f"history_{t}" in named}
    dist = {t: named[f"distributions_{t}"] for t in tasks}
    s = cmp.settings
    parts = [
        "# Controller comparison on the manoeuvre rig",
        "",
        (f"Command: `{s['command']}` ({s['episodes']} episodes per law, task and mode, seed {s['seed']}; {cmp.seconds:.0f} s on "
         f"{s['machine']}).  Every law runs on the same episodes (paired conditions): airspeed drawn per episode, gusts, sensor "
         "noise, quantisation and telemetry delay, Hawk mass +-10 %, servo delay 10-20 ms and bandwidth 5-8 Hz; robust mode adds "
         "+-20 % on every aerodynamic derivative and on friction; gusty mode 5 % gusts unless [conditions] sets them (the "
         f"settings per mode: summary.json).  As flown: {_flown(s)}.  "
         "Success: the task's own criterion.  Numbers are medians over the episodes with their 95 % bootstrap interval "
         f"[low, high]; success rates carry Wilson 95 % intervals.  With {s['episodes']} episodes one episode moves a success rate by "
         f"{100 / s['episodes']:.0f} points."),
        "",
    ]
    parts += verdict(cmp, markdown=True) + [""]
    for mode in s["modes"]:
        parts += [f"## {mode.capitalize()}", ""] + _md_tables([r for r in cmp.rows if r["mode"] == mode])
    parts += ["Metrics:", "", *_glossary(), ""]
    parts += ["## Episodes", "", "Left: one episode (every law on identical conditions); right: every episode.", ""]
    for t in tasks:
        parts += [f"### {t}", ""]
        parts += ([f"![history {t}]({hist[t].name})"] if t in hist else []) + [f"![distributions {t}]({dist[t].name})", ""]
    parts += ["## All tasks", "", "![metrics](metrics.png)", ""]
    parts += ["## Loop margins (linear model, servo and Pade delay in the loop)", "", _margins_md(cmp.margins), ""]
    if cmp.skipped:
        parts += ["## Skipped", ""] + [f"- {x['controller']} on {x['task']}: {x['reason']}" for x in cmp.skipped] + [""]
    if s.get("policies"):
        parts += ["## Law files", ""] + [f"- {k}: `{v['path']}` ({v['kind']}, task {v['task']}, sha256 {v['sha256'][:12]})"
                                         for k, v in s["policies"].items()] + [""]
    (out / "report.md").write_text("\n".join(parts) + "\n")
    return files
