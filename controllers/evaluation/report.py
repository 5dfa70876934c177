"""Plots and the one-page Markdown report of a comparison (:mod:`controllers.evaluation.compare`).

Files: ``history_<task>.png`` (first recorded nominal episode, identical conditions for every law:
the task's tracked quantity against its reference, the commanded rate when there is one, the
tracking error, every command a law used, and the other free rig joints; :func:`plot_history`), ``metrics.png`` (bars per task and law, nominal solid, robust
hatched) and ``report.md``.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from controllers.evaluation.summary import COLUMNS, Comparison

BAR_METRICS = (("success_rate", "success rate, %"), ("rms_error", "RMS tracking error, deg"), ("settling_time", "settling time, s"),
               ("overshoot_pct", "overshoot, %"), ("control_effort", "control effort, RMS action"), ("control_rate", "control rate, RMS 1/s"))
COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_history(res: Any, path: Path) -> Path:
    """Time histories of episode 0 of every law of one evaluation result.

    Panels: the task's tracked quantity against its reference (``Task.display``: roll angle, rig pitch or
    yaw, the model's alpha, the level error), the commanded rate when the task has one, the tracking error,
    every command some law used (aileron, elevator, rudder, Hawk surfaces), and the free rig joints other
    than the tracked one."""
    plt = _plt()
    names = list(res.history)
    h0 = res.history[names[0]]
    disp = dict(getattr(res, "display", {}) or {})
    label, joint, rate = disp.get("label", "tracked quantity, deg"), disp.get("joint"), disp.get("rate")
    act_names = list(disp.get("actions", ("comp_aileron", "comp_elevator", "comp_rudder")))
    used = [k for k in range(h0["action"].shape[-1])
            if any(np.nanmax(np.abs(res.history[n]["action"][0, :, k]), initial=0.0) > 1e-3 for n in names)]
    extra = [j for j, k in (("rig_pitch", 1), ("rig_yaw", 2))
             if k != joint and np.any(np.isfinite(h0["q"][0, :, k])) and np.nanmax(np.abs(h0["q"][0, :, k])) > 1e-9]
    panels = ["tracked", *(["rate"] if rate is not None else []), "error", *(f"action{k}" for k in used), *extra]
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 2.1 * len(panels) + 0.6), sharex=True, squeeze=False)
    t = h0["t"]
    for ax, panel in zip(axes[:, 0], panels):
        for c, name in enumerate(names):
            h = res.history[name]
            col = COLORS[c % len(COLORS)]
            if panel == "tracked":
                ax.plot(t, h["y"][0], color=col, lw=1.4, label=name)
            elif panel == "rate":
                ax.plot(t, h["qd"][0, :, rate[0]], color=col, lw=1.4, label=name)
            elif panel == "error":
                ax.plot(t, h["y_ref"][0] - h["y"][0], color=col, lw=1.2, label=name)
            elif panel.startswith("action"):
                ax.plot(t, 40.0 * h["action"][0, :, int(panel[6:])], color=col, lw=1.0, label=name)
            else:
                ax.plot(t, h["q"][0, :, 1 if panel == "rig_pitch" else 2], color=col, lw=1.2, label=name)
        if panel == "tracked":
            ax.plot(t, h0["y_ref"][0], "k--", lw=1.0, label="reference")
            ax.set_ylabel(label)
            ax.legend(loc="best", fontsize=8, ncol=len(names) + 1)
        elif panel == "rate":
            ax.plot(t, h0["ref"][0, :, rate[1]], "k--", lw=1.0, label="reference")
            ax.set_ylabel(disp.get("rate_label") or "rate, deg/s")
        elif panel == "error":
            ax.axhline(0.0, color="0.6", lw=0.8)
            ax.set_ylabel("error, deg")
            lim = np.nanpercentile(np.abs(np.concatenate([res.history[n]["y_ref"][0] - res.history[n]["y"][0] for n in names])), 98)
            lim = lim if np.isfinite(lim) else 1.0
            ax.set_ylim(-1.2 * max(lim, 0.1), 1.2 * max(lim, 0.1))
        elif panel.startswith("action"):
            k = int(panel[6:])
            ax.set_ylabel(f"{act_names[k].replace('comp_', '').replace('_', ' ')} cmd, deg", fontsize=9)
        else:
            ax.set_ylabel(f"{panel}, deg")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time, s")
    fig.suptitle(f"{res.task}: episode 0 ({res.conditions} conditions, seed {res.seed}), same conditions for every law", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_metrics(cmp: Comparison, path: Path) -> Path:
    """Grouped bars: x = task, one bar per law, nominal solid and robust hatched."""
    plt = _plt()
    tasks = list(dict.fromkeys(r["task"] for r in cmp.rows))
    laws = list(dict.fromkeys(r["controller"] for r in cmp.rows))
    modes = list(dict.fromkeys(r["mode"] for r in cmp.rows))
    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    width = 0.8 / max(1, len(laws) * len(modes))
    for ax, (key, label) in zip(axes.ravel(), BAR_METRICS):
        for li, law in enumerate(laws):
            for mi, mode in enumerate(modes):
                vals = []
                for task in tasks:
                    r = [x for x in cmp.rows if x["task"] == task and x["controller"] == law and x["mode"] == mode]
                    vals.append(r[0][key] if r else math.nan)
                x = np.arange(len(tasks)) + (li * len(modes) + mi - (len(laws) * len(modes) - 1) / 2) * width
                bars = ax.bar(x, vals, width, color=COLORS[li % len(COLORS)], hatch="//" if mode != "nominal" else None,
                              edgecolor="k", lw=0.4, alpha=0.9 if mode == "nominal" else 0.55, label=f"{law} ({mode})")
                if key == "success_rate":  # a zero bar is invisible: print every value
                    # upright, so that neighbouring bars' numbers do not run into one another
                    ax.bar_label(bars, labels=[("-" if not np.isfinite(v) else f"{v:.0f}") for v in vals], fontsize=6, padding=1, rotation=90)
        ax.set_xticks(np.arange(len(tasks)))
        ax.set_xticklabels([textwrap.fill(t.replace("_", " "), 10, break_long_words=False) for t in tasks], fontsize=7)  # wrapped: side by side they overlap
        for ti, task in enumerate(tasks):  # a task without this metric (no step segments) says so, not an empty slot
            if not any(np.isfinite(x[key]) for x in cmp.rows if x["task"] == task):
                ax.text(ti, 0.0, "n/a", ha="center", va="bottom", fontsize=7, color="0.4")
        ax.set_title(label, fontsize=10)
        if key == "success_rate":
            ax.set_ylim(0, 120)
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 8), fontsize=8, frameon=False)
    fig.suptitle("Controller comparison: means over episodes (robust: hatched, +-20 % aero derivatives and friction)", fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _md_table(rows: list[dict[str, Any]]) -> str:

    head = "| task | law | " + " | ".join(f"{h} ({u})" for _, h, u, _ in COLUMNS) + " |"
    sep = "|---|---|" + "---:|" * len(COLUMNS)
    body = ["| " + " | ".join([r["task"], r["controller"]] + [("-" if not np.isfinite(r[k]) else f.format(r[k])) for k, _, _, f in COLUMNS]) + " |"
            for r in rows]
    return "\n".join([head, sep, *body])


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


def verdict(rows: list[dict[str, Any]]) -> list[str]:
    """Per task and mode: the law with the highest success rate, ties broken by the lower RMS error."""
    out = []
    for mode in dict.fromkeys(r["mode"] for r in rows):
        for task in dict.fromkeys(r["task"] for r in rows):
            rs = [r for r in rows if r["mode"] == mode and r["task"] == task]
            if not rs:
                continue
            best = max(rs, key=lambda r: (r["success_rate"], -r["rms_error"] if np.isfinite(r["rms_error"]) else -math.inf))
            out.append(f"- {task}, {mode}: **{best['controller']}** (success {best['success_rate']:.0f} %, RMS error {best['rms_error']:.2f})")
    return out


def _f(x: Any) -> str:
    try:
        return f"{float(x):.1f}"
    except (TypeError, ValueError):
        return str(x)


def write(cmp: Comparison, out: Path) -> list[Path]:
    """Write the plots and report.md; returns the plot paths."""
    files = [plot_history(r, out / f"history_{r.task}.png") for r in cmp.results if r.conditions == "nominal"]
    files.append(plot_metrics(cmp, out / "metrics.png"))
    s = cmp.settings
    parts = [
        "# Controller comparison on the manoeuvre rig",
        "",
        (f"Command: `{s['command']}` "
         f"({s['episodes']} episodes per law, task and mode; {cmp.seconds:.0f} s on {s['machine']}).  Every law runs on the same "
        "episodes (paired conditions): airspeed U(15, 25) m/s, gusts 1 % of airspeed (a tunnel's turbulence), sensor noise, "
        "quantisation and one period of telemetry delay, Hawk mass +-10 %, servo delay 10-20 ms and bandwidth 5-8 Hz.  Robust "
         "mode adds +-20 % on every aerodynamic derivative and on friction; gusty mode (on request) 5 % gusts.  Metrics: "
         "`rig_env.envs.metrics`; success: the task's criterion."),
        "",
    ]
    parts += ["## Which law", "", "Highest success rate, then lowest RMS tracking error:", "", *verdict(cmp.rows), ""]
    for mode in s["modes"]:
        parts += [f"## {mode.capitalize()}", "", _md_table([r for r in cmp.rows if r["mode"] == mode]), ""]
    parts += ["## Loop margins (linear model, servo and Pade delay in the loop)", "", _margins_md(cmp.margins), ""]
    if cmp.skipped:
        parts += ["## Skipped", ""] + [f"- {x['controller']} on {x['task']}: {x['reason']}" for x in cmp.skipped] + [""]
    parts += ["## Plots", "", "![metrics](metrics.png)", ""] + [f"![{p.stem}]({p.name})" for p in files if p.stem.startswith("history_")]
    (out / "report.md").write_text("\n".join(parts) + "\n")
    return files
