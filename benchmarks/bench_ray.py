"""The Ray backend's cost against the local one, and what a cluster would reach.

    NUMBA_CACHE_DIR=... python benchmarks/bench_ray.py [--task bank_to_bank] [--episodes 64] [--chunks 8 16 32 64]

One batch of the comparison (``pid`` and ``lqr`` on ``--task``, nominal conditions, ``--episodes`` episodes each)
is run in the same process

1. locally: :func:`controllers.evaluation.evaluate.evaluate` of the whole batch, and of batches of each chunk
   size (the cost of one chunk without Ray: a fixed part, mostly the step loop's Python, and a part per episode;
   fitted as ``t(m) = a + b m``); the laws are designed once and built from their data for each batch, as the
   Ray backend's tasks build them;
2. on a local Ray cluster of **one CPU** (the same CPU budget as the local run: the difference is Ray's cost) at
   each chunk size: :func:`controllers.evaluation.ray_backend.evaluate_ray`, after one warm-up run (worker
   start, imports, the numba cache loaded once per node);
3. on a local Ray cluster of two CPUs (this machine's), the whole batch at the default chunk size.

Ray's own cost per task is ``o = (T_ray(m) - sum over chunks of t(m_chunk)) / chunks``.  On paper, K one-CPU nodes
reach ``K m / (a + b m + o)`` episodes per second with chunks of m episodes (the driver's joins and Tune aside),
and a batch of n episodes pays once Ray's start-up and per-task costs are below what the split saves:
``T_local(n) = a + b n`` against ``S + ceil(n / (K m)) (a + b m + o)``.  The numbers are printed as a table and as
JSON (for benchmarks/RESULTS.md, "Ray backend").
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")  # loopback only (before ray is imported)
# one CPU for the local run as for each Ray task (their workers get the same settings, distributed.worker_env):
# before numpy and numba load.  Left at the defaults, the local run's two BLAS and numba threads fight the
# shared host's other jobs and the same batch took 3x as long as in a one-thread Ray worker (measured).
for _v in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

from controllers.design.conditions import NOMINAL  # noqa: E402
from controllers.evaluation.evaluate import evaluate  # noqa: E402
from controllers import LoopSpec, make_controller  # noqa: E402
from controllers.evaluation.ray_backend import chunks_of, default_chunk_size, evaluate_ray, factory_of  # noqa: E402
from rig_env.envs import RigVectorEnv  # noqa: E402
from rig_env import distributed  # noqa: E402

LAWS = ("pid", "lqr")
_LAWS: dict[str, object] = {}


def _laws(task: str) -> dict[str, object]:
    """The laws as rig compare sends them to Ray: designed once here, travelling as their plain data."""
    if not _LAWS:
        spec = LoopSpec.from_env(RigVectorEnv(1, task=task, **NOMINAL.env_fields()))
        _LAWS.update({k: factory_of(make_controller(k, spec, 1), k) for k in LAWS})
    return dict(_LAWS)


def _local(task: str, n: int, first: int = 0) -> float:
    laws = _laws(task)
    t0 = time.perf_counter()
    evaluate(laws, task, n_episodes=n, seed=0, conditions=NOMINAL, record=3, first_episode=first)
    return time.perf_counter() - t0


def _ray(task: str, n: int, chunk: int | None) -> tuple[float, int, float]:
    """Wall time, tasks, and the tasks' own time summed (inside the task: set-up, books, the evaluation)."""
    laws = _laws(task)
    t0 = time.perf_counter()
    _, run = evaluate_ray(laws, task, n_episodes=n, seed=0, conditions=NOMINAL, record=3, chunk_size=chunk)
    return time.perf_counter() - t0, len(run.chunks), sum(c["task_s"] for c in run.chunks)


def main(argv: list[str] | None = None) -> dict[str, object]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--task", default="bank_to_bank")
    ap.add_argument("--episodes", type=int, default=64)
    ap.add_argument("--chunks", type=int, nargs="+", default=[8, 16, 64])
    ap.add_argument("--rounds", type=int, default=3, help="rounds; in each, every contender runs once, in turn")
    a = ap.parse_args(argv)
    ray = distributed.require_ray()
    n = a.episodes
    sizes = sorted({m for c in a.chunks for _, m in chunks_of(n, c)} | {n})
    _local(a.task, 4)  # kernels compiled / loaded
    t0 = time.perf_counter()
    ray.init(num_cpus=1, include_dashboard=False, logging_level="ERROR", log_to_driver=False,
             runtime_env={"env_vars": distributed.worker_env()})
    start_s = time.perf_counter() - t0
    _ray(a.task, n, n)  # warm-up: the worker process, imports, numba cache
    # the host is shared (other jobs come and go): every contender runs once per round, in turn; medians over rounds
    loc: dict[int, list[float]] = {m: [] for m in sizes}
    rt: dict[int, list[float]] = {c: [] for c in a.chunks}
    inside: dict[int, list[float]] = {c: [] for c in a.chunks}
    for r in range(a.rounds):
        for m in sizes:
            loc[m].append(_local(a.task, m))
        for c in a.chunks:
            wall, _, own = _ray(a.task, n, c)
            rt[c].append(wall)
            inside[c].append(own)
        print(f"round {r + 1}: local {n}: {loc[n][-1]:.2f} s; ray " + ", ".join(f"chunk {c}: {rt[c][-1]:.2f} s" for c in a.chunks), flush=True)
    ray.shutdown()
    med = {m: float(np.median(v)) for m, v in loc.items()}
    t_local = med[n]
    ms = np.array(sorted(med), dtype=float)
    b, a0 = np.polyfit(ms, [med[int(m)] for m in ms], 1)
    rows = []
    for c in a.chunks:
        k = len(chunks_of(n, c))
        # the same chunks run locally one after another, round by round (same load), then the median
        work = float(np.median([sum(loc[m][r] for _, m in chunks_of(n, c)) for r in range(a.rounds)]))
        t = float(np.median(rt[c]))
        per_task = float(np.median([(rt[c][r] - sum(loc[m][r] for _, m in chunks_of(n, c))) / k for r in range(a.rounds)]))
        rows.append({"chunk": c, "chunks": k, "ray_s": round(t, 3), "local_same_chunks_s": round(work, 3),
                     "inside_tasks_s": round(float(np.median(inside[c])), 3),
                     "overhead_vs_local_s": round(t - t_local, 3), "ray_per_task_s": round(per_task, 4),
                     "ray_runs_s": [round(x, 2) for x in rt[c]]})
    t0 = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, logging_level="ERROR", log_to_driver=False,
             runtime_env={"env_vars": distributed.worker_env()})
    start2 = time.perf_counter() - t0
    _ray(a.task, n, None)
    two, one = [], []
    for _ in range(a.rounds):
        two.append(_ray(a.task, n, None)[0])
        one.append(_local(a.task, n))
    ray.shutdown()
    t2 = float(np.median(two))
    t1 = float(np.median(one))

    o = max(0.0, float(np.median([r["ray_per_task_s"] for r in rows])))
    m_big = max(a.chunks)
    per_chunk = a0 + b * m_big + o
    paper = {}
    for K in (1, 2, 10, 100):
        rate = K * m_big / per_chunk
        # smallest batch (a multiple of 16 episodes) a cluster of K one-CPU nodes runs faster than one local
        # process, Ray's start-up included
        pay = next((nn for nn in range(16, 10**7, 16)
                    if start_s + math.ceil(nn / (K * m_big)) * (a0 + b * min(m_big, nn) + o) < a0 + b * nn), None)
        paper[K] = {"episodes_per_s": round(rate, 1), "pays_from_episodes": pay}
    out = {"task": a.task, "laws": list(LAWS), "episodes": n, "rounds": a.rounds, "local_s": round(t_local, 3),
           "local_runs_s": [round(x, 2) for x in loc[n]],
           "local_fit": {"fixed_s": round(a0, 4), "per_episode_s": round(b, 5)}, "ray_start_s": round(start_s, 2),
           "one_cpu": rows, "two_cpus": {"chunk": default_chunk_size(n, 2), "ray_s": round(t2, 3), "local_s": round(t1, 3),
                                         "speedup_vs_local": round(t1 / t2, 2), "start_s": round(start2, 2)},
           "per_task_overhead_s": round(o, 4), "paper_chunk": m_big, "paper": paper,
           "load_average": [round(x, 2) for x in os.getloadavg()]}
    print(f"\nlocal: {n} episodes x {len(LAWS)} laws {t_local:.2f} s (median of {a.rounds}); a batch of m episodes "
          f"t(m) = {a0:.2f} s + {b * 1e3:.1f} ms m; Ray start-up {start_s:.1f} s")
    print("\n| chunk | tasks | Ray, 1 CPU, s | inside the tasks, s | the same chunks locally, s | Ray - local whole batch, s | Ray's cost per task, s |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['chunk']} | {r['chunks']} | {r['ray_s']:.2f} | {r['inside_tasks_s']:.2f} | {r['local_same_chunks_s']:.2f} | "
              f"{r['overhead_vs_local_s']:+.2f} | {r['ray_per_task_s']:+.3f} |")
    print(f"\ntwo CPUs, chunk {out['two_cpus']['chunk']}: {t2:.2f} s against {t1:.2f} s locally ({t1 / t2:.2f}x)")
    print(f"\non paper, chunks of {m_big}, Ray's cost {o:.3f} s per task:\n| one-CPU nodes | episodes/s | Ray pays from (episodes per batch) |")
    for K, p in paper.items():
        print(f"| {K} | {p['episodes_per_s']} | {p['pays_from_episodes']} |")
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
