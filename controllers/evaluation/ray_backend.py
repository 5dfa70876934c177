"""The comparison's episodes on Ray (``rig compare --backend ray [--address ADDR] [--chunk-size N]``).

:func:`evaluate_ray` splits one batch of :func:`controllers.evaluation.evaluate.evaluate` (every law on one task
and mode, ``n`` episodes each) into chunks of consecutive episodes, runs each chunk as a Ray task (the numba
batch of ``chunk x laws`` environments, exactly as the local backend runs the whole), and joins the chunks'
metrics in episode order.  Episode ``i`` is seeded by its index alone (``seed + i``, see
:mod:`controllers.evaluation.evaluate`), so the joined result is the local one, number for number, whatever the
chunk size, the order in which chunks finish or the worker that ran them.

* Laws travel as factories ``(spec, n) -> Controller`` built in the task for the chunk's size: a designed law as
  its plain data (:class:`DataFactory`, designed once on the driver), a law artefact as its loader.
* Lost work: a worker process or a whole node that dies mid-chunk is a system failure; Ray runs the chunk again
  elsewhere (``max_retries``, :data:`rig_env.distributed.MAX_RETRIES`).  Every start of a chunk is recorded in a
  :class:`rig_env.distributed.Ledger` actor on the driver's node, so the retries are counted and reported
  (:class:`RayRun`) and every episode is accounted for (the join checks that each episode index is present
  exactly once).
* Kernels: each task first fixes the node's numba cache (:func:`rig_env.distributed.node_setup`) and warms the
  kernels of its batch once per process under a node-wide lock (:func:`rig_env.distributed.warm_once`): a
  node compiles once, never once per task.
* Progress: a line every few seconds (episodes done, chunks running, retries) on the progress stream.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, TextIO

import numpy as np

from controllers import Controller, LoopSpec, make_controller
from controllers.design import DESIGNS
from controllers.design.conditions import Conditions
from controllers.evaluation.evaluate import EvalResult, LawFactory, evaluate
from controllers.laws import law_for
from rig_env import distributed
from rig_env.params import RigParams

DEFAULT_CHUNKS_PER_CPU = 2
"""Default chunk size: the episodes split into this many chunks per CPU of the cluster (some balance against a
slow node, few enough that Ray's per-task cost stays small; ``benchmarks/bench_ray.py``)."""
MIN_CHUNK = 4


@dataclass(frozen=True)
class KindFactory:
    """A registered law kind as a picklable factory ``(spec, n) -> Controller``: designed on ``params`` when
    given and the kind has a design (as :func:`controllers.evaluation.compare` builds it locally)."""

    kind: str
    params: RigParams | None = None

    def __call__(self, spec: LoopSpec, n: int) -> Controller:
        designed = self.params is not None and law_for(self.kind, spec) in DESIGNS
        return make_controller(self.kind, spec, n, params=self.params) if designed else make_controller(self.kind, spec, n)


@dataclass(frozen=True)
class DataFactory:
    """A built law as a picklable factory ``(spec, n) -> Controller``: its class and plain data (``law.to_data()``,
    what its artefact stores), rebuilt for ``n`` environments by ``from_data`` without designing it again (the
    design runs once, on the driver; a chunk builds the same runtime a deployed artefact does)."""

    cls: type[Controller]
    data: dict[str, Any]

    def __call__(self, spec: LoopSpec, n: int) -> Controller:
        return self.cls.from_data(self.data, spec, n)


def factory_of(law: Controller | LawFactory, kind: str, params: RigParams | None = None) -> LawFactory:
    """What travels to the tasks for ``law``: a factory as it is, a built law as its data (:class:`DataFactory`),
    or, for a law with no plain-data form, its kind to design again in each chunk (:class:`KindFactory`)."""
    if not isinstance(law, Controller):
        return law
    try:
        return DataFactory(type(law), law.to_data())
    except NotImplementedError:
        return KindFactory(kind, params)


@dataclass
class RayRun:
    """What the Ray backend did for one batch: chunks, their attempts (node, pid of each start), the retries."""

    label: str
    episodes: int
    chunk_size: int
    chunks: list[dict[str, Any]] = field(default_factory=list)
    retries: int = 0
    seconds: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        return {"label": self.label, "episodes": self.episodes, "chunk_size": self.chunk_size, "chunks": self.chunks,
                "retries": self.retries, "seconds": round(self.seconds, 3),
                "nodes": sorted({a["node"] for c in self.chunks for a in c["attempts"]})}


def chunks_of(n: int, chunk_size: int) -> list[tuple[int, int]]:
    """(first episode, episodes) of each chunk of ``n`` episodes; a last chunk of one episode joins the one before
    (numpy's einsum, which some laws' runtimes use, takes another loop, so another summation order, over a
    batch of one than over two or more: a one-episode chunk would differ in the last bit from the local run)."""
    out = [(i, min(chunk_size, n - i)) for i in range(0, n, chunk_size)]
    if len(out) > 1 and out[-1][1] == 1:
        first, m = out[-2]
        out[-2:] = [(first, m + 1)]
    return out


def default_chunk_size(n: int, cpus: int) -> int:
    """``n`` episodes in about :data:`DEFAULT_CHUNKS_PER_CPU` chunks per CPU, at least :data:`MIN_CHUNK` episodes each."""
    return max(MIN_CHUNK, math.ceil(n / (DEFAULT_CHUNKS_PER_CPU * max(cpus, 1))))


def check_chunk(chunk_size: int | None) -> None:
    """:func:`rig_env.distributed.check_chunk_size`, and at least 2 episodes (see :func:`chunks_of`)."""
    distributed.check_chunk_size(chunk_size)
    if chunk_size == 1:
        raise distributed.BackendError("--chunk-size = 1: must be an integer in [2, 100000] (a batch of one rounds "
                                       "differently from the local run's batch)")


def _warm(task: str, fields: dict[str, Any], n: int) -> Callable[[], None]:
    def warm() -> None:
        from rig_env.envs import RigVectorEnv

        env = RigVectorEnv(n, task=task, **fields)
        env.reset(options={"env_seeds": np.arange(n)})
        for _ in range(2):
            env.step(np.zeros((n, len(env.action_names))))
    return warm


def run_chunk(ledger: Any, key: str, laws: Mapping[str, LawFactory], task: str, first: int, m: int, seed: int,
              conditions: Conditions, record: int, env_overrides: Mapping[str, Any] | None) -> dict[str, Any]:
    """One chunk, in a Ray task: episodes ``first .. first + m - 1`` of every law (the body of the remote function)."""
    t0 = time.perf_counter()
    where = distributed.node_setup()
    import ray

    attempt = int(ray.get(ledger.start.remote(key, where)))
    fields = {**conditions.env_fields(task), **dict(env_overrides or {})}
    warm_s = distributed.warm_once(f"{task}|{sorted(fields.items())!r}|{m * len(laws)}", _warm(task, fields, m * len(laws)))
    res = evaluate(dict(laws), task, n_episodes=m, seed=seed, conditions=conditions, record=record,
                   env_overrides=env_overrides, first_episode=first)
    ray.get(ledger.finish.remote(key, m))
    return {"result": res, "attempt": attempt, "first": first, "n": m, "warm_s": warm_s, "task_s": time.perf_counter() - t0, **where}


_remote: Any = None


def _remote_chunk() -> Any:
    global _remote
    if _remote is None:
        ray = distributed.require_ray()
        _remote = ray.remote(num_cpus=1, max_retries=distributed.MAX_RETRIES, retry_exceptions=False)(run_chunk)
    return _remote


def join(parts: list[EvalResult], firsts: list[int], n: int, record: int, seconds: float) -> EvalResult:
    """The chunks' results as one: metrics in episode order (each index exactly once: a ValueError otherwise),
    the first ``record`` episodes' histories, the wall time of the whole."""
    order = np.argsort(firsts)
    parts = [parts[i] for i in order]
    firsts = [firsts[i] for i in order]
    expect = 0
    for f, p in zip(firsts, parts):
        if f != expect:
            raise ValueError(f"chunks: episode {expect} missing or repeated (next chunk starts at {f})")
        expect += p.n_episodes
    if expect != n:
        raise ValueError(f"chunks: {expect} episodes joined, {n} expected")
    p0 = parts[0]
    metrics = {law: {k: np.concatenate([p.metrics[law][k] for p in parts]) for k in p0.metrics[law]} for law in p0.metrics}
    history: dict[str, dict[str, np.ndarray]] = {}
    for law, h0 in p0.history.items():
        history[law] = {"t": h0["t"]}
        for k in h0:
            if k != "t":
                history[law][k] = np.concatenate([p.history[law][k] for p in parts], axis=0)[:min(record, n)]
    build = {law: float(max(p.build_seconds[law] for p in parts)) for law in p0.build_seconds}
    return EvalResult(p0.task, p0.conditions, p0.seed, n, p0.paired, metrics, history, seconds, build, p0.display)


def evaluate_ray(
    laws: Mapping[str, LawFactory],
    task: str,
    *,
    n_episodes: int,
    seed: int,
    conditions: Conditions,
    record: int = 3,
    env_overrides: Mapping[str, Any] | None = None,
    chunk_size: int | None = None,
    progress: TextIO | None = None,
    ledger_name: str | None = None,
) -> tuple[EvalResult, RayRun]:
    """:func:`controllers.evaluation.evaluate.evaluate` of picklable law factories on the connected Ray cluster
    (:func:`rig_env.distributed.connect` first), in chunks of ``chunk_size`` episodes (default
    :func:`default_chunk_size`); the same result as the local call, and what ran where (:class:`RayRun`).
    ``ledger_name``: a name for the books' actor (tests watch it to remove a node mid-run)."""
    ray = distributed.require_ray()
    check_chunk(chunk_size)
    if isinstance(n_episodes, bool) or not isinstance(n_episodes, int) or n_episodes < 1:
        raise ValueError(f"n_episodes = {n_episodes!r}: must be a positive integer")
    size = chunk_size or default_chunk_size(n_episodes, distributed.cluster_cpus())
    parts = chunks_of(n_episodes, size)
    label = f"{task} [{conditions.name}]"
    ledger = distributed.make_ledger(n_episodes, "episodes", name=ledger_name)
    t0 = time.perf_counter()
    laws_ref = ray.put(dict(laws))
    refs = [_remote_chunk().remote(ledger, f"{first}+{m}", laws_ref, task, first, m, seed, conditions, record, env_overrides)
            for first, m in parts]
    out = distributed.wait_all(refs, ledger, label, progress)
    seconds = time.perf_counter() - t0
    snap = ray.get(ledger.snapshot.remote())
    ray.kill(ledger)
    res = join([o["result"] for o in out], [o["first"] for o in out], n_episodes, record, seconds)
    run = RayRun(label, n_episodes, size, seconds=seconds, retries=int(snap["retries"]))
    for o in out:
        key = f"{o['first']}+{o['n']}"
        run.chunks.append({"first": o["first"], "episodes": o["n"], "attempts": snap["attempts"].get(key, []),
                           "finished_on": {"node": o["node"], "pid": o["pid"], "attempt": o["attempt"]},
                           "warm_s": round(o["warm_s"], 3), "task_s": round(o["task_s"], 3), "cache_dir": o["cache_dir"]})
    if progress is not None:
        nodes = len({c["finished_on"]["node"] for c in run.chunks})
        progress.write(f"  ray {label}: {n_episodes} episodes in {len(parts)} chunks of {size} on {nodes} node(s), "
                       f"{run.retries} retried, {seconds:.1f} s\n")
        progress.flush()
    return res, run
