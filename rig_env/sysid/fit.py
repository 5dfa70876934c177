"""``fit``: identify parameters of the rig's model from one or more records.

    fit = sysid.fit([rec, ...], params, estimate=["hawk_aero.CMalpha", "friction.rig_roll.Fc"],
                    method="output_error")     # or "filter_error", "equation_error"
    fit.values, fit.std, fit.correlation, fit.params, fit.residuals

The model fitted is the environments' own (:class:`rig_env.sysid.model.RecordModel`: the whole
multibody rig with friction, servos, delays and stops), so ``fit.params`` flies in ``simulate()``, the
environments and the laws' design as it is.  Methods: :mod:`rig_env.sysid.output_error` (measurement noise
only), :mod:`rig_env.sysid.filter_error` (process noise too: turbulence; the paper's method) and
:mod:`rig_env.sysid.equation_error` (accelerations regressed on differentiated data: fast start values).
"""

from __future__ import annotations

import dataclasses
import inspect
import warnings
from typing import TYPE_CHECKING, Callable, Iterable, Mapping, Sequence

import numpy as np

from rig_env.params import ParameterError, RigParams
from rig_env.params_io import IDENTIFICATION_METHODS
from rig_env.sysid.checks import MIN_RECORD_SAMPLES, check_record_names, is_integer, is_number
from rig_env.sysid.covariance import correlation
from rig_env.sysid.parameters import ParameterSet
from rig_env.sysid.records import FlightRecord, RecordError
from rig_env.sysid.result import Fit

if TYPE_CHECKING:
    from rig_env.sysid.output_error import Solution

METHODS = IDENTIFICATION_METHODS
"""The fitting methods (one list: the parameter file's, which records the method of each identified value)."""

MISFIT_R2 = 0.9
"""An output whose simulated response explains less than this fraction of the measured one's variance (R^2) ..."""
MISFIT_P = 1e-6
"""... with residuals far from white (Ljung-Box p-value below this) is flagged (:func:`misfit_warnings`).  Over a
record's hundreds of samples a slight colour (quantisation, a sensor filter) gives p-values of 1e-3 or 1e-4 on a
good fit; a misfit that matters gives Ljung-Box statistics in the thousands, p 1e-100 and below."""
MISFIT_SNR = 10.0
"""... on an output whose variance is at least this many times its residuals' white part (:func:`misfit_warnings`)."""


class FitWarning(UserWarning):
    """A fit that converged to something its own residuals call into doubt (:func:`misfit_warnings`)."""


def _check_request(records: object, params: object, method: object, max_iter: object, tol: object,
                   progress: object) -> tuple[list[FlightRecord], int, float]:
    """The checks of :func:`fit`'s arguments that need no model: (the records as a list, max_iter, tol)."""
    if method not in METHODS:
        raise ValueError(f"method = {method!r}; allowed: {', '.join(METHODS)}")
    if not isinstance(params, RigParams):
        raise ParameterError("params must be a RigParams (e.g. RigParams.default() or RigParams.from_toml(path))")
    if not (is_integer(max_iter) and 1 <= max_iter <= 1000):  # type: ignore[operator]
        raise ValueError(f"max_iter = {max_iter!r}: allowed an integer in [1, 1000]")
    if not (is_number(tol) and 0.0 < tol < 1.0):  # type: ignore[operator]
        raise ValueError(f"tol = {tol!r}: allowed a number in (0, 1)")
    if progress is not None and not callable(progress):
        raise ValueError(f"progress = {progress!r}: give a function taking one line (str) per iteration, or None")
    if isinstance(records, FlightRecord):
        recs = [records]
    elif isinstance(records, Iterable) and not isinstance(records, (str, bytes, Mapping)):
        recs = list(records)
    else:
        recs = []
    if not recs or not all(isinstance(r, FlightRecord) for r in recs):
        raise RecordError(f"records = {records!r:.80}: give one or more FlightRecord objects (a FlightRecord or a list of them)")
    for r in recs:
        if r.n_t < MIN_RECORD_SAMPLES:
            raise RecordError(f"{r.name}: {r.n_t} sample(s); a record to fit needs at least {MIN_RECORD_SAMPLES} (the residuals' "
                              "whiteness test needs two lags, n // 5)")
    check_record_names([r.name for r in recs])
    return recs, int(max_iter), float(tol)  # type: ignore[call-overload, arg-type]


def fit(
    records: FlightRecord | Sequence[FlightRecord],
    params: RigParams,
    estimate: Sequence[str],
    method: str = "output_error",
    *,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    start: Mapping[str, float] | None = None,
    initial_state: str = "estimate",
    biases: bool = False,
    process_noise: Mapping[str, float] | None = None,
    aero: bool | None = None,
    friction: bool = True,
    stops: bool = True,
    nonlinear_aero: bool = False,
    aero_model: str | None = None,
    max_iter: int = 30,
    tol: float = 1e-6,
    differences: str = "forward",
    progress: Callable[[str], None] | None = None,
) -> Fit:
    """Estimate the parameters named in ``estimate`` from ``records``.

    records: one or more :class:`FlightRecord` (fitted jointly; each uniformly sampled, of at least
    :data:`~rig_env.sysid.checks.MIN_RECORD_SAMPLES` samples, under its own name: the names go into the nuisance
    parameters' and the report's figures' names, :func:`~rig_env.sysid.checks.check_record_names`); params: the rig
    (every parameter not estimated keeps its value); estimate: dotted names (:data:`rig_env.PARAM_NAMES`);
    method: "output_error", "filter_error" or "equation_error"; bounds: {name: (low, high)} within each
    parameter's allowed range; start: {name: start value} (default: the value in params);
    initial_state: "estimate" (each record's initial free angles and rates are estimated with the
    parameters, output error) or "measured" (taken from the record's first samples); biases: estimate a
    constant bias per record and output (output error); process_noise: filter error's start values,
    {joint: std of the process noise on its acceleration, rad/s^2} (default from the records);
    aero (None: on, except for wind-off records, airspeed 0 throughout), friction, stops: the model's terms;
    aero_model: "linear" (default), "tables" or "unsteady" (the unsteady model's parameters, its
    flow-separation time constants, centre-of-pressure travel and wake, act only there; not with equation
    error, which regresses measured states and has no aerodynamic states to take), ``nonlinear_aero=True`` the
    older name of "tables"; max_iter, tol: the optimiser's limits (an integer in [1, 1000], a number in (0, 1));
    progress: None, or called with a one-line message per iteration.

    A fit whose residuals say the model does not follow an output (:func:`misfit_warnings`: a local
    minimum or a missing term) is returned with the messages in ``Fit.warnings``, each also issued as a
    :class:`FitWarning`.
    """
    recs, max_iter, tol = _check_request(records, params, method, max_iter, tol, progress)
    from rig_env.physics.pipeline import resolve_aero_model

    model = resolve_aero_model(aero_model, True if nonlinear_aero else None)
    pset = ParameterSet.build(params, estimate, bounds, start)
    from rig_env.sysid.problem import Problem  # the model and its kernels: imported when a fit runs

    if method == "equation_error":
        from rig_env.sysid.equation_error import equation_error

        if biases or initial_state != "estimate" or process_noise:
            raise ValueError("equation error regresses accelerations: it takes no biases, initial_state or process_noise")
        if model == "unsteady":
            raise ValueError("aero_model = 'unsteady': equation error regresses the measured states, which hold no aerodynamic "
                             "states; use output_error or filter_error")
        sol, models, regs = equation_error(recs, params, pset, aero=aero, friction=friction, stops=stops, aero_model=model,
                                        max_iter=max_iter, progress=progress)
        outs = tuple(tuple(f"{j}_accel" for j in m.record.free_dofs) for m in models)
        times = tuple(m.record.t[rg.keep] for m, rg in zip(models, regs))
        return _result(method, recs, outs, (), pset, params, sol, times)
    if method == "output_error":
        from rig_env.sysid.output_error import output_error

        problem = Problem(recs, params, pset, initial_state=initial_state, biases=biases, aero=aero, friction=friction, stops=stops,
                          aero_model=model, differences=differences)
        sol = output_error(problem, problem.p0, max_iter=max_iter, tol=tol, progress=progress)
    else:
        from rig_env.sysid.filter_error import filter_error

        if biases:
            raise ValueError("biases: the filter-error method here does not estimate output biases (use output error)")
        problem = Problem(recs, params, pset, initial_state="measured", biases=False, aero=aero, friction=friction, stops=stops,
                          aero_model=model)
        sol = filter_error(problem, problem.p0, process_noise=process_noise, max_iter=max_iter, tol=tol, progress=progress)
    result = _result(method, problem.records, problem.outputs, problem.names[pset.k :], pset, params, sol)
    found = misfit_warnings(result)
    for w in found:
        warnings.warn(w, FitWarning, stacklevel=2)
    return dataclasses.replace(result, warnings=found) if found else result


def misfit_warnings(result: Fit) -> tuple[str, ...]:
    """One message per record and output the model does not follow, for output and filter error (equation
    error's residuals are regressed accelerations: none).  All three of:

    1. R^2 below :data:`MISFIT_R2`: the residuals hold more than a tenth of the measured output's variance;
    2. residuals far from white: Ljung-Box p-value below :data:`MISFIT_P`;
    3. an output that moves: its variance at least :data:`MISFIT_SNR` times the residuals' white part, their
       mean square times (1 - r_1), r_1 their lag-1 autocorrelation (a slow misfit is correlated from sample to
       sample, the sensors' noise is not).

    An output that hardly moves has a low R^2 from the sensor noise alone, and a small slow misfit of the other
    outputs' making colours its residuals (the third test keeps it out); a good fit of an imperfect model has
    coloured residuals but a high R^2.  A converged fit that leaves a large, structured misfit on an output that
    moves is at a local minimum (the simulated rig took another path, as a roll that falls back where the record
    rolls over the top: :func:`fit_from_starts`) or lacks a term or a parameter (turbulence, to output error)."""
    if result.method == "equation_error":
        return ()
    from rig_env.sysid.diagnostics import fit_measures, whiteness  # scipy's statistics: when a fit has run

    found = []
    for rec, names, yh, e in zip(result.records, result.outputs, result.predicted, result.residuals):
        y = np.asarray(yh) + np.asarray(e)
        for k, (m, w) in enumerate(zip(fit_measures(yh, e, names), whiteness(e, names))):
            white = m.rms**2 * (1.0 - min(max(float(w.acf[1]), 0.0), 1.0)) if w.acf.size > 1 else m.rms**2
            moves = float(np.var(y[:, k])) >= MISFIT_SNR * white
            if m.r2 < MISFIT_R2 and w.p_value < MISFIT_P and moves:
                found.append(f"{rec.name}: {m.output} is not followed (R^2 {m.r2:.2f} < {MISFIT_R2}, residuals far from white, Ljung-Box "
                             f"p {w.p_value:.1g}): a local minimum, where the simulated rig takes another path (try other start values: "
                             f"sysid.fit_from_starts), or a term or parameter the model lacks (turbulence, to output error: method='filter_error')")
    return tuple(found)


def _result(method: str, records: Sequence[FlightRecord], outputs: Sequence[tuple[str, ...]], nuisance: Sequence[str],
            pset: ParameterSet, params: RigParams, sol: "Solution", times: tuple[np.ndarray, ...] = ()) -> Fit:
    """The :class:`Fit` of a solver's solution: the first k entries of ``sol.p`` are the estimates, then the
    ``nuisance`` parameters (initial states, biases) by name."""
    k = pset.k
    theta = sol.p[:k]
    names = pset.names
    cov = sol.cov[:k, :k]
    cov_w = sol.cov_white[:k, :k]
    fitted = pset.apply(params, theta)
    return Fit(
        method=method,
        estimate=names,
        values={n: float(v) for n, v in zip(names, theta)},
        initial={n: float(v) for n, v in zip(names, pset.start)},
        std={n: float(np.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(names)},
        std_white={n: float(np.sqrt(max(cov_w[i, i], 0.0))) for i, n in enumerate(names)},
        covariance=cov,
        correlation=correlation(cov),
        params=fitted,
        records=tuple(records),
        outputs=tuple(outputs),
        predicted=tuple(sol.evaluation.Y),
        residuals=tuple(sol.residuals),
        noise_cov=sol.noise[0],
        nuisance={n: float(v) for n, v in zip(nuisance, sol.p[k:])},
        process_noise=dict(sol.extra.get("process_noise", {})),
        cost_history=tuple(sol.cost_history),
        iterations=sol.iterations,
        converged=sol.converged,
        message=sol.message,
        times=times,
    )


def fit_from_starts(
    records: FlightRecord | Sequence[FlightRecord],
    params: RigParams,
    estimate: Sequence[str],
    starts: Sequence[Mapping[str, float]],
    **options: object,
) -> Fit:
    """:func:`fit` from each of several start values; the fit of lowest final cost (``cost_history[-1]``, output
    and filter error's negative log-likelihood of the same records) among those that converged, else among all.

    For a cost with more than one minimum: a record in which the rig rolls over the top only with enough control
    power (the default rig's measured roll imbalance) has a local minimum below the truth, where the simulated
    roll falls back (docs: README, Identification).  ``starts``: one ``{name: value}`` per run (a name missing
    from one keeps ``params``' value there, as :func:`fit`'s ``start``); ``options``: :func:`fit`'s other keywords.
    Every start and option is checked before the first fit runs.  The returned fit's ``message`` lists every
    start's estimates and cost.
    """
    if isinstance(estimate, str):
        raise ValueError(f"estimate = {estimate!r}: give a list of names (dotted names of rig_env.PARAM_NAMES), e.g. [{estimate!r}]")
    if isinstance(starts, Mapping) or not isinstance(starts, Sequence) or len(starts) == 0:
        raise ValueError("starts: give a non-empty list of {name: start value} mappings, one per run")
    if not all(isinstance(s, Mapping) for s in starts):
        raise ValueError("starts: every entry must be a {name: start value} mapping")
    if "start" in options:
        raise ValueError("start: give the start values in starts")
    try:
        call = inspect.signature(fit).bind(records, params, estimate, **options)
    except TypeError as e:
        raise ValueError(f"options: {e} (fit_from_starts takes fit's keywords)") from None
    call.apply_defaults()
    a = call.arguments
    _check_request(records, params, a["method"], a["max_iter"], a["tol"], a["progress"])
    ParameterSet.build(params, estimate, a["bounds"])  # the names and bounds, once
    unknown = sorted({n for s in starts for n in s if not isinstance(n, str) or n not in estimate}, key=str)
    if unknown:
        raise ValueError(f"starts: {unknown} not among the estimated parameters {list(estimate)}")
    for i, s in enumerate(starts):  # every start's values, before the first fit runs
        try:
            ParameterSet.build(params, estimate, a["bounds"], s)
        except ParameterError as e:
            raise ParameterError(f"starts[{i}]: {e}") from None
    with warnings.catch_warnings():  # a start that ends in a local minimum is expected here: only the best fit's are told
        warnings.simplefilter("ignore", FitWarning)
        fits = [fit(records, params, estimate, start=dict(s), **options) for s in starts]  # type: ignore[arg-type]
    pool = [f for f in fits if f.converged and f.cost_history] or [f for f in fits if f.cost_history] or fits
    best = min(pool, key=lambda f: f.cost_history[-1] if f.cost_history else np.inf)
    for w in best.warnings:
        warnings.warn(w, FitWarning, stacklevel=2)
    lines = [f"start {i + 1}: " + ", ".join(f"{n} {f.values[n]:.6g}" for n in f.estimate)
             + (f", cost {f.cost_history[-1]:.6g}" if f.cost_history else "") + ("" if f.converged else " (not converged)")
             for i, f in enumerate(fits)]
    return dataclasses.replace(best, message=f"{best.message}; best of {len(fits)} starts (" + "; ".join(lines) + ")")
