"""The identification report's figures (matplotlib on an Agg canvas, no pyplot): PNG files, every axis with its unit.

Outputs are shown in degrees (angles) and degrees per second (rates): an output named after a joint
(``model_pitch``) is an angle in rad, ``<joint>_rate`` a rate in rad/s (:func:`output_scale`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from rig_env.params import JOINTS
from rig_env.sysid.diagnostics import Whiteness


def output_scale(name: str) -> tuple[float, str]:
    """(factor from the model's unit, display unit) of an output: joint angle rad -> deg, joint rate rad/s -> deg/s, joint acceleration (equation error) rad/s^2 -> deg/s^2."""
    if name in JOINTS:
        return 180.0 / math.pi, "deg"
    if name.endswith("_rate") and name[: -len("_rate")] in JOINTS:
        return 180.0 / math.pi, "deg/s"
    if name.endswith("_accel") and name[: -len("_accel")] in JOINTS:
        return 180.0 / math.pi, "deg/s^2"
    return 1.0, "model units"


def _label(name: str) -> str:
    k, unit = output_scale(name)
    return f"{name.replace('_', ' ')}, {unit}"


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def time_history(path: Path, t: np.ndarray, outputs: Sequence[str], predicted: np.ndarray, residuals: np.ndarray, title: str) -> Path:
    """Measured (predicted + residual) and predicted outputs against time (left) and the residuals (right).

    t: (n_t,) s; predicted, residuals: (n_t, n_out) in the model's units (shown in deg, deg/s).
    """
    n = len(outputs)
    fig = _figure(12.0, 2.2 * n + 0.8)
    axes = fig.subplots(n, 2, sharex=True, squeeze=False)
    for k, name in enumerate(outputs):
        s, unit = output_scale(name)
        a, b = axes[k]
        a.plot(t, s * (predicted[:, k] + residuals[:, k]), color="0.35", lw=1.0, label="measured")
        a.plot(t, s * predicted[:, k], color="C0", lw=1.2, label="predicted")
        a.set_ylabel(_label(name))
        b.plot(t, s * residuals[:, k], color="C3", lw=0.8)
        b.axhline(0.0, color="0.6", lw=0.6)
        b.set_ylabel(f"residual, {unit}")
        if k == 0:
            a.legend(loc="upper right", fontsize=8)
            a.set_title("measured and predicted")
            b.set_title("residual (measured - predicted)")
    axes[-1, 0].set_xlabel("time, s")
    axes[-1, 1].set_xlabel("time, s")
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    return path


def autocorrelation(path: Path, dt: float, white: Sequence[Whiteness], title: str) -> Path:
    """Normalised residual autocorrelation per output against lag (s) with the 95 % band +-1.96/sqrt(N)."""
    n = len(white)
    fig = _figure(7.0, 1.9 * n + 0.8)
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for ax, w in zip(axes, white):
        lags = np.arange(w.max_lag + 1) * dt
        ax.vlines(lags, 0.0, w.acf, color="C0", lw=1.2)
        ax.plot(lags, w.acf, "o", color="C0", ms=3)
        ax.axhspan(-w.band, w.band, color="C2", alpha=0.2, label=f"95 % band for white noise, +-{w.band:.3f}")
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.set_ylabel("autocorrelation, -")
        ax.set_title(f"{w.output}: {100 * w.fraction_outside:.0f} % of lags outside, Ljung-Box p = {w.p_value:.3g}", fontsize=9)
        ax.set_ylim(min(-1.05 * w.band, 1.1 * w.acf.min() - 0.05), 1.05)
        ax.legend(loc="upper right", fontsize=7)
    axes[-1].set_xlabel("lag, s")
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    return path


def correlation(path: Path, names: Sequence[str], corr: np.ndarray, title: str) -> Path:
    """The estimates' correlation matrix (dimensionless, -1..1), values written in the cells up to 14 parameters."""
    k = len(names)
    size = max(4.5, 0.55 * k + 2.5)
    fig = _figure(size + 1.0, size)
    ax = fig.subplots()
    im = ax.imshow(corr, vmin=-1.0, vmax=1.0, cmap="RdBu_r")
    ax.set_xticks(range(k), names, rotation=60, ha="right", fontsize=8)
    ax.set_yticks(range(k), names, fontsize=8)
    if k <= 14:
        for i in range(k):
            for j in range(k):
                ax.text(j, i, f"{corr[i, j]:.2f}", ha="center", va="center", fontsize=7, color="w" if abs(corr[i, j]) > 0.6 else "k")
    fig.colorbar(im, ax=ax, label="correlation coefficient, -")
    ax.set_title(title)
    fig.savefig(path, dpi=110)
    return path


def cost_history(path: Path, cost: Sequence[float], title: str) -> Path:
    """The cost per iteration (as the method defines it; log scale when all positive)."""
    fig = _figure(6.0, 3.2)
    ax = fig.subplots()
    c = np.asarray(cost, dtype=np.float64)
    ax.plot(np.arange(c.size), c, "o-", color="C0", ms=3)
    if c.size and np.all(c > 0):
        ax.set_yscale("log")
    ax.set_xlabel("iteration, -")
    ax.set_ylabel("cost (the method's), -")
    ax.grid(True, alpha=0.3)
    ax.set_title(title)
    fig.savefig(path, dpi=110)
    return path
