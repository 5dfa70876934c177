"""Compile the kernels a run will use, in parallel processes, before the run needs them.

A fresh installation compiles its numba kernels on first use, one after another in the one process
that needs them: the lane kernel for each aerodynamic model the tasks fly (the linear one, the high-incidence tables), the
linearisation's right-hand side (the designed laws), each task's and the sensors' kernels.  They are
independent, and numba's disk cache is shared between processes, so :func:`precompile` compiles them
side by side in ``processes`` child interpreters (``python -m rig_env.precompile``), each taking the
tasks of one physics kernel: each child builds the task's :class:`rig_env.envs.RigVectorEnv` with the
run's configuration at the batch sizes of both the serial and the parallel kernel, resets and steps it
once, and the design child trims and linearises the rig.  The caller then loads every kernel from the
cache in a fraction of a second.  While the children work, one line every few seconds says so.

A run that finds its work done (a marker file in numba's cache directory, named by a hash of the
tasks, the configuration and the batch sizes; the cache directory itself is named by a hash of the
physics sources, so an edited kernel is a new directory) starts no process.  A child that fails is
reported in one line and changes nothing else: its kernels then compile in the caller, as without this
module.  With one process, or in a process that runs its kernels as Python, nothing is done.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

SIZES = (8, 64)
"""Batch sizes warmed: one under and one over ``integrator.PARALLEL_MIN_ENVS`` (serial and parallel kernels)."""


@dataclass
class PrecompileReport:
    """What :func:`precompile` did: ``skipped`` (the reason, or "" when it ran), ``seconds`` of wall time,
    ``jobs`` (each child's tasks and ``seconds``), ``failed`` (the children that failed, with their last message)."""

    skipped: str = ""
    seconds: float = 0.0
    jobs: list[dict[str, Any]] = field(default_factory=list)
    failed: list[dict[str, Any]] = field(default_factory=list)


def _plain(x: Any) -> Any:
    if isinstance(x, Mapping):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if hasattr(x, "item") and callable(x.item):
        return x.item()
    return x


def _tuples(x: Any) -> Any:
    """JSON's lists back to the tuples the configuration was given as (ranges, pairs)."""
    if isinstance(x, dict):
        return {k: _tuples(v) for k, v in x.items()}
    if isinstance(x, list):
        return tuple(_tuples(v) for v in x)
    return x


def _marker(spec: dict[str, Any]) -> Path | None:
    from rig_env.physics import jit

    if jit.mode() != "numba":
        return None
    numba = jit.setup_numba()
    cache = str(getattr(numba.config, "CACHE_DIR", "") or "")
    if not cache:
        return None
    from rig_env import __version__

    digest = hashlib.sha256(json.dumps({**spec, "version": __version__}, sort_keys=True).encode()).hexdigest()[:16]
    return Path(cache) / f"precompiled-{digest}.json"


def _kernel_kind(task: str, fields: Mapping[str, Any]) -> str:
    from rig_env.envs import TASKS
    from rig_env.envs.config import RigEnvConfig
    from rig_env.physics.pipeline import resolve_aero_model

    # from the task and the configuration (validated: a ValueError names a bad field), without building an
    # environment, whose construction compiles the sensors' kernels here in the parent before any child starts
    cfg = RigEnvConfig().with_overrides(task=task, **fields)
    model = resolve_aero_model(cfg.aero_model, cfg.nonlinear_aero, TASKS[task].default_aero_model)
    return f"lanes/{model}"  # every environment runs the lane kernel; one compiled kernel per aerodynamic model


KERNEL_SECONDS = {"lanes/linear": 40.0, "lanes/tables": 55.0, "lanes/unsteady": 70.0}
"""Rough cold-compile seconds of a group's physics kernel (the parallel version, compiled first; its serial twin then
adds about a second) on the 2-core machine the defaults were measured on (``benchmarks/RESULTS.md``, "A new user's
first run"; 36 and 49 s on a loaded one; the unsteady one since its RK stage 0 was peeled, about 18 % more:
"Aerodynamic models"); others 40 s.  Only their ratios matter: they balance the jobs."""
TASK_SECONDS = 2.0
"""... each further task of a group (its own small kernels)."""
DESIGN_SECONDS = 12.0
"""... the design's trim and linearisation (14 s measured on a loaded machine)."""


def _parallel(n: int) -> bool:
    from rig_env.physics.integrator import PARALLEL_MIN_ENVS

    return int(n) >= PARALLEL_MIN_ENVS


def _jobs(tasks: Sequence[str], fields: Mapping[str, Any], design: bool, processes: int) -> list[dict[str, Any]]:
    """Tasks grouped by physics kernel and aerodynamic model (each group's first task compiles that kernel: the
    costly part), the design a job of its own; while there are more jobs than ``processes``, the cheapest
    (by :data:`KERNEL_SECONDS`, :data:`TASK_SECONDS`, :data:`DESIGN_SECONDS`) is folded into the next
    cheapest, so that the longest job, which the caller waits for, is as short as the estimates allow."""
    groups: dict[str, list[str]] = {}
    for t in tasks:
        groups.setdefault(_kernel_kind(t, fields), []).append(t)

    jobs = [{"tasks": ts, "design": False, "cost": KERNEL_SECONDS.get(g, 40.0) + TASK_SECONDS * (len(ts) - 1)}
            for g, ts in sorted(groups.items(), key=lambda kv: kv[0] != "lanes/linear")]
    if design:
        jobs.append({"tasks": [], "design": True, "cost": DESIGN_SECONDS})
    while len(jobs) > processes:
        jobs.sort(key=lambda j: j["cost"])
        a = jobs.pop(0)
        jobs[0] = {"tasks": jobs[0]["tasks"] + a["tasks"], "design": jobs[0]["design"] or a["design"], "cost": jobs[0]["cost"] + a["cost"]}
    return [{"tasks": j["tasks"], "design": j["design"]} for j in jobs]


def precompile(
    tasks: Sequence[str],
    env_fields: Mapping[str, Any] | None = None,
    *,
    design: bool = True,
    sizes: Sequence[int] = SIZES,
    batch_sizes: Mapping[str, int] | None = None,
    processes: int | None = None,
    stream: TextIO | None = None,
    interval: float = 3.0,
    timeout: float = 900.0,
    while_waiting: Callable[[], object] | None = None,
) -> PrecompileReport:
    """Compile the kernels of ``tasks`` (with the configuration ``env_fields``) and, with ``design``, of the
    linearisation, in up to ``processes`` child processes (default: ``RIG_ENV_PRECOMPILE_PROCESSES`` if set,
    else the CPUs, at most 3; 1 turns the parallel compile off); progress on ``stream``.  See the module docstring.
    ``batch_sizes``: the environments of a task's batches, when the caller knows them (task name to count): that
    task is then stepped at that size only, which compiles the one version of its physics kernel (serial or
    parallel, :data:`rig_env.physics.integrator.PARALLEL_MIN_ENVS`) the caller will run, not both; the other
    tasks at ``sizes``.  ``timeout``: seconds before a child is
    stopped (its kernels then compile in the caller).  ``while_waiting``: called once while the children
    compile (work of the caller's that needs no kernel, e.g. importing the plotting library)."""
    from rig_env.envs import TASKS

    bad = [t for t in tasks if t not in TASKS]
    if bad:
        raise ValueError(f"tasks: unknown {bad}; valid names: {sorted(TASKS)}")
    fields = _plain(dict(env_fields or {}))
    env_proc = os.environ.get("RIG_ENV_PRECOMPILE_PROCESSES", "").strip()
    if processes is None and env_proc:
        try:
            processes = int(env_proc)
        except ValueError:
            raise ValueError(f"RIG_ENV_PRECOMPILE_PROCESSES = {env_proc!r}: must be a positive integer") from None
    n_proc = processes if processes is not None else max(1, min(os.cpu_count() or 1, 3))
    if not isinstance(n_proc, int) or n_proc < 1:
        raise ValueError(f"processes = {processes!r}: must be a positive integer")
    plain_sizes = sorted(int(s) for s in sizes)
    task_sizes = {t: ([int((batch_sizes or {})[t])] if t in (batch_sizes or {}) else plain_sizes) for t in sorted(tasks)}
    spec = {"tasks": sorted(tasks), "fields": fields, "design": design, "sizes": task_sizes}
    marker = _marker(spec)
    if marker is None:
        return PrecompileReport(skipped="kernels run as Python (nothing to compile)")
    if marker.exists():
        return PrecompileReport(skipped="compiled by an earlier run")
    if n_proc < 2:
        return PrecompileReport(skipped="one process: the kernels compile where they are first used")
    jobs = _jobs(list(tasks), _tuples(fields), design, n_proc)
    t0 = time.perf_counter()
    if stream is not None:
        stream.write(f"  compiling the numba kernels in {len(jobs)} processes (once per installation; later runs load them "
                     "from the disk cache in a second)\n")
        stream.flush()
    procs = []
    for job in jobs:
        payload = json.dumps({**job, "fields": fields, "sizes": {t: task_sizes[t] for t in job["tasks"]}})
        # the child's messages go to a file, not a pipe: a pipe read only at the end would stall a chatty child
        log = tempfile.TemporaryFile(mode="w+")
        proc = subprocess.Popen([sys.executable, "-m", "rig_env.precompile", payload], stdout=subprocess.DEVNULL, stderr=log, text=True)
        procs.append((job, time.perf_counter(), proc, log))
    report = PrecompileReport()
    if while_waiting is not None:
        while_waiting()
    last = time.perf_counter()
    running = list(procs)
    while running:
        time.sleep(0.25)
        now = time.perf_counter()
        for item in list(running):
            job, start, proc, log = item
            if proc.poll() is None and now - start > timeout:
                proc.kill()
            if proc.poll() is not None:
                running.remove(item)
                proc.wait()
                log.seek(0)
                err = log.read()[-20000:]
                log.close()
                what = ", ".join(job["tasks"] + (["design"] if job["design"] else []))
                entry = {"tasks": job["tasks"], "design": job["design"], "seconds": round(now - start, 1)}
                report.jobs.append(entry)
                if proc.returncode != 0:
                    msg = (err.strip().splitlines() or ["no message"])[-1]
                    report.failed.append({**entry, "message": msg})
                    if stream is not None:
                        stream.write(f"  note: compiling ({what}) failed ({msg}); those kernels compile when first used\n")
                elif stream is not None:
                    stream.write(f"  compiled ({what}) in {now - start:.0f} s\n")
                if stream is not None:
                    stream.flush()
        if running and stream is not None and now - last >= interval:
            last = now
            stream.write(f"  compiling the numba kernels: {now - t0:4.0f} s, {len(running)} of {len(procs)} processes running\n")
            stream.flush()
    report.seconds = time.perf_counter() - t0
    if not report.failed:
        try:
            marker.parent.mkdir(parents=True, exist_ok=True)
            tmp = marker.with_suffix(f".tmp{os.getpid()}")
            tmp.write_text(json.dumps({**spec, "seconds": round(report.seconds, 1)}))
            os.replace(tmp, marker)
        except OSError:
            pass  # the cache itself is what matters; without the marker the next run checks again
    return report


def _child(payload: str) -> None:
    """One job: step each task's environment once at each of its sizes whose physics kernel version (serial or
    parallel) an earlier task of the job has not compiled yet, and at least once; trim and linearise with ``design``."""
    import numpy as np

    job = json.loads(payload)
    fields = _tuples(job["fields"])
    sizes = job["sizes"]
    from rig_env.envs import RigVectorEnv

    done: set[tuple[str, bool]] = set()  # (kernel, parallel) compiled by an earlier task of this job
    for task in job["tasks"]:
        mine = [int(n) for n in (sizes[task] if isinstance(sizes, dict) else sizes)]
        kind = _kernel_kind(task, fields)
        # the tasks of a group share its physics kernel; each needs its own (small) kernels once, at the largest size.
        # Largest first: the parallel version compiles the physics step, and the serial twin then adds about a second
        # (the other way round the parallel loop adds 10-20 s)
        for n in sorted([n for n in mine if (kind, _parallel(n)) not in done] or mine[-1:], reverse=True):
            done.add((kind, _parallel(n)))
            env = RigVectorEnv(int(n), task=task, **fields)
            env.reset(seed=0)
            env.step(np.zeros((int(n), len(env.action_names))))
    if job["design"]:
        from rig_env.linear import linearize, trim
        from rig_env.params import RigParams

        p = RigParams.default()
        linearize(p, trim(p, free_dofs=("model_pitch",), airspeed=20.0))


if __name__ == "__main__":
    _child(sys.argv[1])
