"""The identification report: ``report.md`` with PNG figures, its tables laid out as the paper's Tables 3 and 4.

:func:`write_report` writes, for one fit or several (a 1-DOF and a 2-DOF test, as Tables 3 and 4):

* the estimates, one table per body (Hawk model, compensator, friction of each joint, mass and
  geometry, servos...), one row per estimated parameter: start value (the previous estimate),
  estimate, its 95 % interval (estimate +- 1.96 sigma), the Cramer-Rao standard error corrected for
  coloured residuals and the uncorrected (white-residual) one, the relative standard error, and, given
  ``reference`` (a simulation's truth, the paper's table), the reference value and (estimate -
  reference) / sigma;  with several fits, the estimates side by side as well;
* the correlation matrix (figure) and the pairs with |r| > 0.9;
* per record, measured and predicted outputs against time with the residuals, and the residuals'
  autocorrelation with its 95 % band;  the whiteness and fit-measure table
  (:mod:`rig_env.sysid.diagnostics`);
* the method, iterations, convergence and cost history; the measurement-noise estimate; the
  estimated initial conditions and biases, and filter error's process noise.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from rig_env.params import PARAM_INDEX, PARAM_NAMES
from rig_env.params_io import did_you_mean
from rig_env.sysid import figures
from rig_env.sysid.checks import check_record_names, is_number, record_slug
from rig_env.sysid.diagnostics import BAND_Z, fit_measures, whiteness
from rig_env.sysid.result import Fit

HIGH_CORRELATION = 0.9
"""|r| above which a pair of estimates is listed as poorly separated."""

_SYMBOLS = {"CMq": "CMq + CMalphadot"}
"""Parameter labels as the paper's tables write them (the file's CMq is the sum)."""


def body_of(name: str) -> str:
    """The body a dotted parameter name belongs to, as the report groups it."""
    parts = name.split(".")
    if parts[0] == "hawk_aero":
        return "Hawk model"
    if parts[0] == "comp_aero":
        return "Compensator"
    if parts[0] == "friction" and len(parts) == 3:
        return f"Friction, {parts[1].replace('_', ' ')}"
    if parts[0] == "mass":
        return "Mass properties"
    return parts[0].replace("_", " ").capitalize()


def _unit(fit: Fit, name: str) -> str:
    parts = name.split(".")
    try:
        parent = functools.reduce(getattr, parts[:-1], fit.params)
        meta = {f.name: f.metadata for f in dataclasses.fields(parent)}
        return str(meta[parts[-1]].get("unit", ""))
    except (AttributeError, KeyError, TypeError):
        return ""


def _label(name: str) -> str:
    leaf = name.split(".")[-1]
    return f"{_SYMBOLS.get(leaf, leaf)} (`{name}`)"


def fmt(v: float, digits: int = 4) -> str:
    """A number as the tables write it: ``digits`` significant figures."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    return f"{v:.{digits}g}"


def estimates_table(fit: Fit, reference: Mapping[str, float] | None = None) -> str:
    """The Tables 3/4 layout: a Markdown table per body, one row per estimated parameter."""
    groups: dict[str, list[str]] = {}
    for name in fit.estimate:
        groups.setdefault(body_of(name), []).append(name)
    ref = dict(reference or {})
    head = ["parameter", "unit", "start (previous)", "estimate", "95 % interval", "sigma (CR, coloured)", "sigma (CR, white)", "relative sigma (sigma / abs. estimate), %"]
    if ref:
        head += ["reference", "(estimate - reference) / sigma"]
    out = []
    for body, names in groups.items():
        out += [f"**{body}**", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for n in names:
            v, s, sw = float(fit.values[n]), float(fit.std[n]), float(fit.std_white[n])
            rel = 100.0 * s / abs(v) if v != 0 else float("nan")
            row = [_label(n), _unit(fit, n) or "-", fmt(float(fit.initial[n])), fmt(v),
                   f"[{fmt(v - BAND_Z * s)}, {fmt(v + BAND_Z * s)}]", fmt(s), fmt(sw), fmt(rel, 3)]
            if ref:
                if n in ref:
                    r = float(ref[n])
                    row += [fmt(r), fmt((v - r) / s, 3) if s > 0 else "-"]
                else:
                    row += ["-", "-"]
            out.append("| " + " | ".join(row) + " |")
        out.append("")
    return "\n".join(out)


def high_correlations(fit: Fit, threshold: float = HIGH_CORRELATION) -> list[tuple[str, str, float]]:
    """Pairs of estimates with |r| > threshold, largest first."""
    c = np.asarray(fit.correlation)
    pairs = [(fit.estimate[i], fit.estimate[j], float(c[i, j])) for i in range(len(fit.estimate)) for j in range(i + 1, len(fit.estimate))
             if abs(c[i, j]) > threshold]
    return sorted(pairs, key=lambda p: -abs(p[2]))


def _noise_table(fit: Fit) -> list[str]:
    R = np.atleast_2d(np.asarray(fit.noise_cov, dtype=np.float64))
    names = fit.outputs[0] if fit.outputs and len(fit.outputs[0]) == R.shape[0] else tuple(f"y{k}" for k in range(R.shape[0]))
    rows = ["| output | noise sigma | unit |", "|---|---|---|"]
    for k, n in enumerate(names):
        s, unit = figures.output_scale(n)
        rows.append(f"| {n} | {fmt(s * math.sqrt(max(R[k, k], 0.0)))} | {unit} |")
    return rows


def _fit_section(fit: Fit, k: int, prefix: str, out: Path, reference: Mapping[str, float] | None) -> list[str]:
    recs = ", ".join(r.name for r in fit.records)
    lines = [f"## Fit {k}: {fit.method.replace('_', ' ')} on {recs}", ""]
    status = "converged" if fit.converged else "NOT converged"
    cost = fit.cost_history
    lines += [f"Method `{fit.method}`; {fit.iterations} iterations, {status}" + (f" ({fit.message})" if fit.message else "") + "; "
              + (f"cost {fmt(cost[0])} at the start, {fmt(cost[-1])} at the end." if cost else "no cost history."), ""]
    if fit.warnings:
        lines += ["**Warnings** (the residuals, `rig_env.sysid.misfit_warnings`):", ""] + [f"- {w}" for w in fit.warnings] + [""]
    lines += ["### Estimates", "",
              "Cramer-Rao standard errors sigma: \"coloured\" is corrected for the residuals' autocorrelation, \"white\" assumes "
              "white residuals (the uncorrected bound, smaller when the residuals are coloured).  The interval is estimate +- 1.96 sigma "
              "(coloured).", "", estimates_table(fit, reference)]
    if len(fit.estimate) > 1:
        fig = figures.correlation(out / figure_name("correlation", prefix), list(fit.estimate), np.asarray(fit.correlation), f"Fit {k}: correlation of the estimates")
        lines += ["### Correlation of the estimates", "", f"![correlation]({fig.name})", ""]
        pairs = high_correlations(fit)
        if pairs:
            lines += [f"Pairs with |r| > {HIGH_CORRELATION} (poorly separated by these records):", ""]
            lines += [f"- `{a}` and `{b}`: r = {r:+.3f}" for a, b, r in pairs] + [""]
        else:
            lines += [f"No pair with |r| > {HIGH_CORRELATION}.", ""]
    if cost:
        fig = figures.cost_history(out / figure_name("cost", prefix), cost, f"Fit {k}: cost per iteration")
        lines += ["### Convergence", "", f"![cost history]({fig.name})", ""]
    lines += ["### Measurement noise estimate", "", "Standard deviations (square roots of the noise covariance's diagonal), "
              "of the first record's outputs.", "", *_noise_table(fit), ""]
    extra = [("Estimated initial conditions and biases", fit.nuisance), ("Process noise (filter error), standard deviations", fit.process_noise)]
    for head, vals in extra:
        if vals:
            lines += [f"### {head}", "", "| name | value (model units: rad, rad/s) |", "|---|---|"]
            lines += [f"| `{n}` | {fmt(float(v))} |" for n, v in vals.items()] + [""]
    lines += ["### Residuals", "",
              "Per record and output: the fraction of autocorrelation lags 1..L outside the 95 % band +-1.96/sqrt(N) (white noise: "
              "5 %, with the 95 % range of Binomial(L, 0.05) / L in brackets), the Ljung-Box statistic Q (chi-squared, L degrees of "
              "freedom, for white residuals) and its p-value (small: coloured residuals), R^2, Theil's U (0 perfect, 1 no agreement) "
              "and the residual RMS.", "",
              "| record | output | N | L | lags outside band, % | Q | p-value | R^2 | Theil U | residual RMS | unit |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    plots = []
    for i, (rec, names, yh, e) in enumerate(zip(fit.records, fit.outputs, fit.predicted, fit.residuals)):
        t = fit.times[i] if fit.times else rec.t
        white = whiteness(e, names)
        meas = fit_measures(yh, e, names)
        for w, m in zip(white, meas):
            s, unit = figures.output_scale(w.output)
            lo, hi = w.outside_range
            lines.append(f"| {rec.name} | {w.output} | {w.n} | {w.max_lag} | {100 * w.fraction_outside:.1f} [{100 * lo:.0f}, {100 * hi:.0f}] | "
                         f"{fmt(w.q)} | {fmt(w.p_value, 3)} | {fmt(m.r2)} | {fmt(m.theil_u, 3)} | {fmt(s * m.rms)} | {unit} |")
        th = figures.time_history(out / figure_name("history", prefix, rec.name), t, names, yh, e, f"Fit {k}, {rec.name}: outputs and residuals")
        ac = figures.autocorrelation(out / figure_name("acf", prefix, rec.name), rec.dt, white, f"Fit {k}, {rec.name}: residual autocorrelation")
        plots += [f"#### {rec.name}", "", f"![time history]({th.name})", "", f"![residual autocorrelation]({ac.name})", ""]
    return lines + ["", "### Time histories and residual autocorrelation", "", *plots]


def _side_by_side(fits: Sequence[Fit]) -> list[str]:
    names = list(dict.fromkeys(n for f in fits for n in f.estimate))
    head = ["parameter"] + [f"fit {k + 1} ({f.method.replace('_', ' ')}), estimate +- sigma" for k, f in enumerate(fits)]
    rows = ["## Estimates side by side", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for n in names:
        cells = [f"{fmt(float(f.values[n]))} +- {fmt(float(f.std[n]))}" if n in f.values else "-" for f in fits]
        rows.append(f"| {_label(n)} | " + " | ".join(cells) + " |")
    return rows + [""]


def figure_name(kind: str, prefix: str = "", record: str | None = None) -> str:
    """A figure's file name (the one place it is spelled): ``<prefix><kind>.png``, or with a record
    ``<prefix><kind>_<record's slug>.png`` (kinds: correlation, cost; history, acf per record)."""
    return f"{prefix}{kind}.png" if record is None else f"{prefix}{kind}_{record_slug(record)}.png"


def figure_names(n_estimates: int, record_names: Sequence[str], *, cost: bool = True, prefix: str = "") -> list[str]:
    """The file names of one fit's figures as :func:`write_report` names them (``prefix``: ``fitK_`` with several fits).

    n_estimates: the number of estimated parameters (a correlation figure with more than one); record_names:
    the records' names (a time history and an autocorrelation figure each); cost: whether the fit has a cost
    history (a cost figure).  Known before the fit from the configuration and the records read.
    """
    names = [figure_name("correlation", prefix)] if n_estimates > 1 else []
    names += [figure_name("cost", prefix)] if cost else []
    for r in record_names:
        names += [figure_name("history", prefix, r), figure_name("acf", prefix, r)]
    return list(dict.fromkeys(names))


def report_files(fit: Fit | Sequence[Fit], out_dir: str | Path) -> list[Path]:
    """Every file :func:`write_report` writes for ``fit`` into ``out_dir``: ``report.md`` and its figures."""
    fits = [fit] if isinstance(fit, Fit) else list(fit)
    out = Path(out_dir)
    names = ["report.md"]
    for k, f in enumerate(fits, start=1):
        names += figure_names(len(f.estimate), [r.name for r in f.records], cost=bool(f.cost_history),
                              prefix=f"fit{k}_" if len(fits) > 1 else "")
    return [out / n for n in dict.fromkeys(names)]


def write_report(fit: Fit | Sequence[Fit], out_dir: str | Path, *, reference: Mapping[str, float] | None = None,
                 title: str = "System identification", overwrite: bool = False) -> Path:
    """Write ``out_dir/report.md`` and its PNG figures for one fit or several; returns the report's path.

    reference: ``{dotted name: value}`` in the parameter file's units (a simulation's truth, a table of
    the paper), shown beside the estimates; names of :data:`rig_env.PARAM_NAMES` (those not estimated are
    not shown), numbers.  Refused before anything is written: an unknown reference name (ValueError), a fit
    whose records' figures would be one file (two records of one name, or of names alike but for characters a
    file name cannot hold: RecordError, :func:`~rig_env.sysid.checks.check_record_names`), and, unless
    ``overwrite``, a ``report.md`` or any of its figures (:func:`report_files`) already there (FileExistsError).
    """
    fits = [fit] if isinstance(fit, Fit) else list(fit)
    if not fits or not all(isinstance(f, Fit) for f in fits):
        raise ValueError("fit: give a Fit or a non-empty sequence of Fits")
    if reference is not None:
        if not isinstance(reference, Mapping):
            raise ValueError(f"reference = {reference!r:.80}: give a mapping {{dotted parameter name: value}} or None")
        for n, v in reference.items():
            if not isinstance(n, str) or n not in PARAM_INDEX:
                hint = did_you_mean(n, PARAM_NAMES) if isinstance(n, str) else ""
                raise ValueError(f"reference: unknown parameter {n!r}{hint}; valid names: rig_env.PARAM_NAMES")
            if not is_number(v):
                raise ValueError(f"reference[{n!r}] = {v!r}: must be a number (the parameter file's units)")
    for k, f in enumerate(fits, start=1):  # each record's figures named apart (the fits' by their prefix)
        prefix = f"fit{k}_" if len(fits) > 1 else ""

        def per_record(n: str, prefix: str = prefix) -> tuple[str, str]:
            return figure_name("history", prefix, n), figure_name("acf", prefix, n)

        check_record_names([r.name for r in f.records], per_record)
    out = Path(out_dir)
    path = out / "report.md"
    there = [str(p) for p in report_files(fits, out) if p.exists()] if not overwrite else []
    if there:
        raise FileExistsError(f"{', '.join(there)} exist(s); pass overwrite=True (rig identify: --overwrite) to replace")
    out.mkdir(parents=True, exist_ok=True)
    lines = [f"# {title}", ""]
    for k, f in enumerate(fits, start=1):
        recs = ", ".join(f"{r.name} ({r.duration:.1f} s at {1.0 / r.dt:.0f} Hz, free: {', '.join(r.free_dofs)})" for r in f.records)
        lines.append(f"- Fit {k}: `{f.method}`, {len(f.estimate)} parameters, records {recs}")
    lines.append("")
    if len(fits) > 1:
        lines += _side_by_side(fits)
    for k, f in enumerate(fits, start=1):
        lines += _fit_section(f, k, f"fit{k}_" if len(fits) > 1 else "", out, reference)
    path.write_text("\n".join(lines).rstrip("\n") + "\n")
    return path
