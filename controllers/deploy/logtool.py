"""``rig-deploy log show|plot|export FILE``: a flight's log (:mod:`rig_env.framelog_format`) as a summary, plots or CSV.

``show`` prints the summary (JSON): header (artefact, kind, task, rate), duration, ticks, time in each
state, faults and when they latched, frames fresh / missed / corrupt / foreign / old, timing percentiles
(latency = command sent - deadline, wake jitter, law compute), and a torn last record if any.
``plot --out DIR`` writes four PNGs (commands, joints, state / faults, timing; matplotlib's Agg backend,
units on every axis) to a new or empty folder, refusing to overwrite a file.  ``export --out FILE.csv``
writes one row per record (vector fields as ``name_<joint or surface>``), refusing an existing file.
Every message names its path; a damaged log (cut header, a second header) is refused, exit 2.
"""

from __future__ import annotations

import argparse
import json
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from rig_env.framelog_format import TornLogWarning, read_log
from rig_env.params import JOINTS, SURFACES


def _codes() -> tuple[tuple[str, ...], dict[int, str]]:
    """The loop's state names and fault bits (imported when used: building the parser must not load the loop)."""
    from controllers.deploy.loop import FAULTS, STATES

    return STATES, FAULTS

__all__ = ["add_parser", "export_csv", "plot", "summarise"]

JOINT_NAMES, SURFACE_NAMES = JOINTS, SURFACES  # the record's ``angles`` and ``action`` / ``command`` orders
PLOTS = ("commands.png", "joints.png", "states.png", "timing.png")


def _read(path: str) -> tuple[dict[str, Any], np.ndarray]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TornLogWarning)  # reported in the summary as torn_bytes
        return read_log(path)


def _pct(x: np.ndarray) -> dict[str, float | None]:
    if x.size == 0:
        return {"p50_ms": None, "p99_ms": None, "max_ms": None}
    return {"p50_ms": float(np.percentile(x, 50) * 1e3), "p99_ms": float(np.percentile(x, 99) * 1e3), "max_ms": float(x.max() * 1e3)}


def summarise(path: str) -> dict[str, Any]:
    """The summary of the log at ``path`` (see the module docstring); times in s, timing in ms."""
    state_names, fault_bits = _codes()
    header, r = _read(path)
    rate = float(header.get("rate_hz", 0.0)) or None
    period = 1.0 / rate if rate else 0.0
    n = int(r.size)
    out: dict[str, Any] = {"path": str(path), "header": {k: v for k, v in header.items() if k not in ("dtype", "torn_bytes")},
                           "records": n, "torn_bytes": header.get("torn_bytes", 0)}
    if n == 0:
        return out
    ticks = int(r["tick"][-1]) + 1
    states = {s: {"ticks": int(np.sum(r["state"] == i)), "s": float(np.sum(r["state"] == i) * period)} for i, s in enumerate(state_names)}
    faults = []
    prev = np.concatenate([[0], r["fault"][:-1]])
    for bit, name in fault_bits.items():
        for i in np.flatnonzero((r["fault"] & bit) & ~(prev & bit)):
            faults.append({"fault": name, "tick": int(r["tick"][i]), "t_s": float(r["deadline"][i]), "rig_time_s": float(r["rig_time"][i])})
    faults.sort(key=lambda f: f["tick"])
    comp = r["compute"][r["compute"] > 0]
    out.update({
        "duration_s": float(r["deadline"][-1] - r["deadline"][0] + period), "ticks": ticks, "skipped_ticks": ticks - n,
        "states": states, "faults": faults,
        "frames": {"fresh": int(np.sum(r["fresh"] == 1)), "missed": int(np.sum(r["fresh"] == 0)), "corrupt": int(r["n_corrupt"][-1]),
                   "foreign": int(r["n_foreign"][-1]), "old": int(r["n_old"][-1])},
        "latency": _pct(r["send"] - r["deadline"]), "wake_jitter": _pct(np.abs(r["wake"] - r["deadline"])), "compute": _pct(comp),
    })
    return out


def _new_file(path: Path) -> None:
    if os.path.lexists(path):
        raise FileExistsError(17, "already exists; refusing to overwrite it", str(path))


def export_csv(path: str, out: str) -> int:
    """Write the records of the log ``path`` as CSV to the new file ``out``; returns the row count."""
    _header, r = _read(path)
    cols: list[tuple[str, np.ndarray]] = []
    for name in r.dtype.names or ():
        v = r[name]
        if v.ndim == 1:
            cols.append((name, v))
        else:
            names = JOINT_NAMES if name == "angles" else SURFACE_NAMES if name in ("action", "command") else [str(i) for i in range(v.shape[1])]
            cols += [(f"{name}_{names[i]}", v[:, i]) for i in range(v.shape[1])]
    o = Path(out)
    _new_file(o)
    tmp = o.with_name(o.name + ".tmp")
    try:
        with open(tmp, "x", encoding="ascii") as f:
            f.write(",".join(c for c, _ in cols) + "\n")
            f.writelines(",".join(repr(float(v[i])) if v.dtype.kind == "f" else str(int(v[i])) for _, v in cols) + "\n" for i in range(r.size))
        os.link(tmp, o)  # fails if ``out`` appeared meanwhile: never overwrites
    finally:
        tmp.unlink(missing_ok=True)
    return int(r.size)


def plot(path: str, out_dir: str) -> list[str]:
    """Write commands, joints, states / faults and timing PNGs of the log ``path`` into ``out_dir`` (new or without them)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    state_names, fault_bits = _codes()
    header, r = _read(path)
    d = Path(out_dir)
    targets = [d / name for name in PLOTS]
    for t in targets:
        _new_file(t)
    d.mkdir(parents=True, exist_ok=True)
    t = r["deadline"]
    free = header.get("free_dofs") or list(JOINT_NAMES)
    figs: list[tuple[Path, Any]] = []
    fig, ax = plt.subplots(figsize=(9, 4))
    for i, s in enumerate(SURFACE_NAMES):
        if np.any(r["command"][:, i] != 0):
            ax.plot(t, np.degrees(r["command"][:, i]), label=s)
    ax.set(xlabel="time since start, s", ylabel="surface command, deg", title=f"commands: {path}")
    ax.legend(loc="upper right", fontsize=8) if ax.lines else None
    figs.append((targets[0], fig))
    fig, ax = plt.subplots(figsize=(9, 4))
    for j in free:
        if j in JOINT_NAMES:
            ax.plot(t, np.degrees(r["angles"][:, JOINT_NAMES.index(j)]), label=j)
    ax.set(xlabel="time since start, s", ylabel="joint angle, deg", title="free joints (frames as received)")
    ax.legend(loc="upper right", fontsize=8) if ax.lines else None
    figs.append((targets[1], fig))
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    a1.step(t, r["state"], where="post")
    a1.set(ylabel="state (code)", yticks=range(len(state_names)), yticklabels=state_names)
    for bit, name in fault_bits.items():
        on = (r["fault"] & bit) != 0
        if on.any():
            a2.step(t, on * 1, where="post", label=name)
    a2.step(t, r["missed"], where="post", color="k", lw=0.8, label="missed frames")
    a2.set(xlabel="time since start, s", ylabel="fault bit (0/1); missed frames, count")
    a2.legend(loc="upper right", fontsize=8)
    figs.append((targets[2], fig))
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot(t, (r["send"] - r["deadline"]) * 1e3, ".", ms=2, label="latency (sent - deadline)")
    ax.plot(t, (r["wake"] - r["deadline"]) * 1e3, ".", ms=2, label="wake - deadline")
    ax.plot(t, r["compute"] * 1e3, ".", ms=2, label="law compute")
    ax.set(xlabel="time since start, s", ylabel="time, ms", title="timing per tick")
    ax.legend(loc="upper right", fontsize=8)
    figs.append((targets[3], fig))
    for target, f in figs:
        with open(target, "xb") as fh:
            f.savefig(fh, format="png", dpi=100)
        plt.close(f)
    return [str(p) for p in targets]


def cmd_log(a: argparse.Namespace) -> int:
    if a.action == "show":
        print(json.dumps(summarise(a.file), indent=1))
    elif a.action == "export":
        out = a.out or a.file + ".csv"
        n = export_csv(a.file, out)
        print(f"wrote {out}: {n} records")
    else:
        out = a.out or a.file + ".plots"
        for p in plot(a.file, out):
            print(f"wrote {p}")
    return 0


def add_parser(sub: Any) -> None:
    """Add ``log show|plot|export FILE [--out]`` to the ``rig-deploy`` subparsers ``sub``."""
    g = sub.add_parser("log", help="a flight's log: summary, plots, CSV")
    g.add_argument("action", choices=("show", "plot", "export"))
    g.add_argument("file", help="a log written by rig-deploy run --log")
    g.add_argument("--out", help="plot: a folder (default FILE.plots); export: a new CSV file (default FILE.csv); existing files are refused")
    g.set_defaults(func=cmd_log)
