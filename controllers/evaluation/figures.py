"""The figures of a comparison's report (:mod:`controllers.evaluation.report` writes the page around them).

Files: ``history_<task>.png`` (first recorded nominal episode, identical conditions for every law, its
airspeed in the title: the task's tracked quantity against its reference, the commanded rate when there
is one, the tracking error, every command a law used, and the other free rig joints; :func:`plot_history`),
``distributions_<task>.png`` (box plots over the episodes, per law and mode; :func:`plot_distributions`)
and ``metrics.png`` (medians per task and law with their 95 % intervals, nominal solid, other modes
hatched; :func:`plot_metrics`).
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from controllers.evaluation.score import episode_scores
from controllers.evaluation.summary import BY_KEY, Comparison

BAR_METRICS = ("success", "rms_error", "hold_error", "saturation", "cmd_rate_rms", "score")
BOX_METRICS = ("rms_error", "hold_error", "saturation", "cmd_rate_rms", "cmd_freq", "score")
COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def preload() -> None:
    """Import matplotlib (Agg) now: half a second a caller can spend while it waits for something else."""
    _plt()


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
    v = np.asarray(res.metrics[names[0]].get("airspeed", [np.nan]), dtype=float)[0]
    at = f"airspeed {v:.1f} m/s, " if np.isfinite(v) else ""
    fig.suptitle(f"{res.task}: episode 0 ({at}{res.conditions} conditions, seed {res.seed}), same conditions for every law", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _label(key: str) -> str:
    if key == "success":
        return "success, % (Wilson 95 %)"
    if key == "score":
        return "score (1 best)"
    m = BY_KEY[key]
    return f"{m.header}, {m.unit}"


def _stat(r: dict[str, Any], key: str) -> tuple[float, float, float]:
    """(value, low, high) of a row's success (%), score or metric median."""
    if key == "success":
        return 100 * r["success"], 100 * r["success_ci95"][0], 100 * r["success_ci95"][1]
    if key == "score":
        return r["score"], *r["score_ci95"]
    s = r["metrics"].get(key)
    return (math.nan, math.nan, math.nan) if s is None else (s["median"], *s["ci95"])


def plot_metrics(cmp: Comparison, path: Path) -> Path:
    """Grouped bars: x = task, one bar per law and mode (nominal solid, others hatched), 95 % intervals as error bars."""
    plt = _plt()
    tasks = list(dict.fromkeys(r["task"] for r in cmp.rows))
    laws = list(dict.fromkeys(r["law"] for r in cmp.rows))
    modes = list(dict.fromkeys(r["mode"] for r in cmp.rows))
    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    width = 0.8 / max(1, len(laws) * len(modes))
    for ax, key in zip(axes.ravel(), BAR_METRICS):
        for li, law in enumerate(laws):
            for mi, mode in enumerate(modes):
                vals, los, his = [], [], []
                for task in tasks:
                    r = [x for x in cmp.rows if x["task"] == task and x["law"] == law and x["mode"] == mode]
                    v, lo, hi = _stat(r[0], key) if r else (math.nan,) * 3
                    vals.append(v), los.append(v - lo if np.isfinite(lo) else 0.0), his.append(hi - v if np.isfinite(hi) else 0.0)
                x = np.arange(len(tasks)) + (li * len(modes) + mi - (len(laws) * len(modes) - 1) / 2) * width
                bars = ax.bar(x, vals, width, color=COLORS[li % len(COLORS)], hatch="//" if mode != "nominal" else None,
                              edgecolor="k", lw=0.4, alpha=0.9 if mode == "nominal" else 0.55, label=f"{law} ({mode})",
                              yerr=[np.maximum(los, 0), np.maximum(his, 0)], error_kw={"elinewidth": 0.7, "capsize": 1.5})
                if key == "success":  # a zero bar is invisible: print every value, upright so neighbours do not collide
                    ax.bar_label(bars, labels=[("-" if not np.isfinite(v) else f"{v:.0f}") for v in vals], fontsize=6, padding=1, rotation=90)
        ax.set_xticks(np.arange(len(tasks)))
        ax.set_xticklabels([textwrap.fill(t.replace("_", " "), 10, break_long_words=False) for t in tasks], fontsize=7)
        for ti, task in enumerate(tasks):  # a task without this metric (no step segments) says so, not an empty slot
            if not any(np.isfinite(_stat(x, key)[0]) for x in cmp.rows if x["task"] == task):
                ax.text(ti, 0.0, "n/a", ha="center", va="bottom", fontsize=7, color="0.4")
        ax.set_title(_label(key), fontsize=10)
        if key == "success":
            ax.set_ylim(0, 125)
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 8), fontsize=8, frameon=False)
    fig.suptitle("Controller comparison: medians over episodes with 95 % bootstrap intervals (success: rate with Wilson interval; "
                 "non-nominal modes hatched)", fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_distributions(cmp: Comparison, task: str, path: Path) -> Path:
    """Box plots over the episodes of one task: per law and mode, the metrics of :data:`BOX_METRICS`
    (per-episode score of :func:`controllers.evaluation.score.episode_scores`); points are the episodes."""
    plt = _plt()
    results = [r for r in cmp.results if r.task == task]
    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5))
    for ax, key in zip(axes.ravel(), BOX_METRICS):
        data, labels, colors = [], [], []
        for res in results:
            for li, (law, m) in enumerate(res.metrics.items()):
                if key == "score":
                    v = episode_scores(m, cmp.rule)
                else:
                    met = BY_KEY[key]
                    v = np.asarray(m.get(met.source, np.full(res.n_episodes, np.nan)), dtype=float) * met.scale
                data.append(v[np.isfinite(v)])
                labels.append(f"{law}\n{res.conditions}")
                colors.append(COLORS[li % len(COLORS)])
        if not any(d.size for d in data):
            ax.text(0.5, 0.5, "n/a for this task", ha="center", va="center", transform=ax.transAxes, color="0.4")
        else:
            bp = ax.boxplot([d if d.size else [np.nan] for d in data], patch_artist=True, widths=0.6, showfliers=False)
            for patch, col in zip(bp["boxes"], colors):
                patch.set_facecolor(col)
                patch.set_alpha(0.45)
            rng = np.random.default_rng(0)  # jitter of the points only
            for i, d in enumerate(data):
                ax.plot(i + 1 + 0.12 * rng.uniform(-1, 1, d.size), d, ".", ms=3, color="k", alpha=0.6)
            ax.set_xticks(np.arange(1, len(labels) + 1))
            ax.set_xticklabels(labels, fontsize=7)
        ax.set_title(_label(key), fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(f"{task}: distributions over the episodes (box: quartiles, whiskers: 1.5 IQR, dots: episodes)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
