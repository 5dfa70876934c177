"""Monte-Carlo of identification: many noisy fits of one record, locally or on Ray.

    mc = sysid.monte_carlo(clean, params, ["hawk_aero.CMalpha", "hawk_aero.CMq"], noise_std_rad=np.radians(0.1),
                           seeds=range(50), method="output_error")            # backend="ray": on a cluster
    mc.estimates["hawk_aero.CMq"]   # (50,) one estimate per noise draw, in seed order
    mc.summary(truth)               # per parameter: mean, scatter, mean Cramer-Rao std, std/scatter, bias

Draw ``k`` is the record with the measurement noise of seed ``seeds[k]`` (:meth:`FlightRecord.with_noise`: the
noise is a function of the seed alone) fitted by :func:`rig_env.sysid.fit`; a fit is deterministic, so the Ray
backend (chunks of seeds as Ray tasks, :mod:`rig_env.distributed`; retried after a lost worker or node, the
retries counted) gives the local estimates exactly, whatever the chunking.  What the scatter of the estimates
over the draws says against the fits' own standard errors is what ``tests/test_sysid_fit.py`` checks.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence, TextIO

import numpy as np

from rig_env import distributed
from rig_env.params import RigParams
from rig_env.sysid.fit import FitWarning, fit
from rig_env.sysid.records import FlightRecord


@dataclass(frozen=True)
class MonteCarlo:
    """The fits of every noise draw: ``estimates[name]`` and ``std[name]`` (n,) in ``seeds`` order, each fit's
    iterations and convergence, ``flagged`` (n,) whether its residuals flagged an output the model does not follow
    (:func:`rig_env.sysid.misfit_warnings`; not issued as warnings draw by draw), and how it ran (``backend``; with
    Ray: chunks, nodes, ``retries``)."""

    names: tuple[str, ...]
    seeds: tuple[int, ...]
    estimates: dict[str, np.ndarray]
    std: dict[str, np.ndarray]
    converged: np.ndarray
    iterations: np.ndarray
    seconds: float
    backend: dict[str, Any] = field(default_factory=dict)
    flagged: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def summary(self, truth: Mapping[str, float] | None = None) -> dict[str, dict[str, float]]:
        """Per parameter: ``mean``, ``scatter`` (sample std of the estimates over the draws), ``mean_std`` (the mean
        of the fits' standard errors), ``ratio`` (mean_std / scatter: about 1 when the standard errors are honest)
        and, given the ``truth``, ``bias`` (mean - truth) and ``within_2std`` (fraction of draws within 2 standard
        errors of the truth)."""
        out: dict[str, dict[str, float]] = {}
        for n in self.names:
            e, s = self.estimates[n], self.std[n]
            scatter = float(np.std(e, ddof=1)) if e.size > 1 else math.nan
            row = {"mean": float(np.mean(e)), "scatter": scatter, "mean_std": float(np.mean(s)),
                   "ratio": float(np.mean(s)) / scatter if scatter > 0 else math.nan}
            if truth is not None and n in truth:
                row["bias"] = row["mean"] - float(truth[n])
                row["within_2std"] = float(np.mean(np.abs(e - float(truth[n])) <= 2.0 * s))
            out[n] = row
        return out


def _fits(record: FlightRecord, params: RigParams, estimate: Sequence[str], noise_std_rad: float | Sequence[float],
          seeds: Sequence[int], method: str, fit_kwargs: Mapping[str, Any]) -> list[dict[str, Any]]:
    out = []
    for s in seeds:
        with warnings.catch_warnings():  # counted in MonteCarlo.flagged rather than told draw by draw
            warnings.simplefilter("ignore", FitWarning)
            f = fit(record.with_noise(noise_std_rad, seed=int(s)), params, list(estimate), method, **dict(fit_kwargs))
        out.append({"seed": int(s), "values": dict(f.values), "std": dict(f.std), "converged": bool(f.converged),
                    "iterations": int(f.iterations), "flagged": bool(f.warnings)})
    return out


def _warm_fit(record: FlightRecord, params: RigParams, estimate: Sequence[str], method: str, warm_kw: Mapping[str, Any]) -> None:
    """One iteration of the fit, to compile the kernels on a node (its result, flagged or not, is not used)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        fit(record, params, list(estimate), method, **dict(warm_kw))


def run_chunk(ledger: Any, key: str, record: FlightRecord, params: RigParams, estimate: Sequence[str],
              noise_std_rad: float | Sequence[float], seeds: Sequence[int], method: str,
              fit_kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """One chunk of draws in a Ray task (the body of the remote function): node set-up, books, fits."""
    where = distributed.node_setup()
    import ray

    attempt = int(ray.get(ledger.start.remote(key, where)))
    warm_kw = {**dict(fit_kwargs), "max_iter": 1}
    distributed.warm_once(f"sysid|{record.free_dofs}|{method}",
                          lambda: _warm_fit(record, params, estimate, method, warm_kw))  # the kernels, once per node
    fits = _fits(record, params, estimate, noise_std_rad, seeds, method, fit_kwargs)
    ray.get(ledger.finish.remote(key, len(seeds)))
    return {"fits": fits, "attempt": attempt, **where}


def monte_carlo(
    record: FlightRecord,
    params: RigParams,
    estimate: Sequence[str],
    *,
    noise_std_rad: float | Sequence[float],
    seeds: Sequence[int],
    method: str = "output_error",
    backend: str = "local",
    address: str | None = None,
    chunk_size: int | None = None,
    progress: TextIO | None = None,
    fit_kwargs: Mapping[str, Any] | None = None,
) -> MonteCarlo:
    """Fit ``record`` with the measurement noise of every seed of ``seeds`` added (``noise_std_rad``, rad, one value
    or one per free joint; :meth:`FlightRecord.with_noise`) by :func:`rig_env.sysid.fit` (``method``,
    ``fit_kwargs``: its keyword arguments).  ``backend``: "local" (one process) or "ray" (chunks of ``chunk_size``
    seeds as Ray tasks on the cluster at ``address``, default a local one): the same estimates either way.
    ``progress``: a stream for a line every few seconds on Ray.  A bad option is a ValueError naming it."""
    distributed.check_backend(backend, address)
    distributed.check_chunk_size(chunk_size)
    if isinstance(estimate, str):
        estimate = (estimate,)  # one name, as fit() takes it (it was split into its characters)
    seeds = [int(s) for s in seeds]
    if not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise ValueError(f"seeds = {seeds[:8]!r}{' ...' if len(seeds) > 8 else ''}: a non-empty list of distinct integers >= 0")
    kw = dict(fit_kwargs or {})
    if "progress" in kw:
        raise ValueError("fit_kwargs: no 'progress' (the fits run on workers); use monte_carlo(progress=...)")
    t0 = time.perf_counter()
    info: dict[str, Any] = {"backend": backend}
    if backend == "local":
        fits = _fits(record, params, estimate, noise_std_rad, seeds, method, kw)
    else:
        fits, info = _on_ray(record, params, estimate, noise_std_rad, seeds, method, kw, address, chunk_size, progress)
    fits.sort(key=lambda f: seeds.index(f["seed"]))
    names = tuple(estimate)
    return MonteCarlo(names, tuple(seeds), {n: np.array([f["values"][n] for f in fits]) for n in names},
                      {n: np.array([f["std"][n] for f in fits]) for n in names},
                      np.array([f["converged"] for f in fits]), np.array([f["iterations"] for f in fits]),
                      time.perf_counter() - t0, info, np.array([f["flagged"] for f in fits], dtype=bool))


_remote: list[Any] = []  # the remote function, made at first use (Ray imported only then)


def _on_ray(record: FlightRecord, params: RigParams, estimate: Sequence[str], noise_std_rad: float | Sequence[float],
            seeds: list[int], method: str, kw: dict[str, Any], address: str | None, chunk_size: int | None,
            progress: TextIO | None) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    with distributed.session(address) as ray:
        if not _remote:
            _remote.append(ray.remote(num_cpus=1, max_retries=distributed.MAX_RETRIES, retry_exceptions=False)(run_chunk))
        size = chunk_size or max(1, math.ceil(len(seeds) / (2 * distributed.cluster_cpus())))
        parts = [seeds[i:i + size] for i in range(0, len(seeds), size)]
        ledger = distributed.make_ledger(len(seeds), "fits", name=f"sysid-{time.time_ns()}")
        rec, par = ray.put(record), ray.put(params)
        refs = [_remote[0].remote(ledger, f"{p[0]}+{len(p)}", rec, par, list(estimate), noise_std_rad, p, method, kw) for p in parts]
        out = distributed.wait_all(refs, ledger, f"sysid monte carlo ({method})", progress)
        snap = ray.get(ledger.snapshot.remote())
        ray.kill(ledger)
    fits = [f for o in out for f in o["fits"]]
    info = {"backend": "ray", "chunk_size": size, "chunks": len(parts), "retries": int(snap["retries"]),
            "nodes": sorted({o["node"] for o in out}), "attempts": snap["attempts"]}
    return fits, info
