"""``rig identify CONFIG.toml --out DIR [--overwrite]``: records in, report and identified parameter file out.

The configuration (TOML; paths relative to the configuration file's folder)::

    params = "my_rig.toml"                # base parameter file (default: the default rig)
    method = "output_error"               # or "filter_error", "equation_error"
    estimate = [                          # dotted names of rig_env.PARAM_NAMES, in the report's order
        "hawk_aero.CM0",
        { name = "hawk_aero.CMq", start = -4.0, bounds = [-30.0, 0.0] },
    ]

    [options]                             # optional
    max_iter = 50                         # iterations, >= 1
    tol = 1e-6                            # relative cost change that ends the iterations, > 0
    aero_model = "linear"                 # "linear", "tables" or "unsteady" (its separation, c.p. and wake parameters)

    [[record]]                            # one per record, at least one
    path = "runs/pitch_3211.csv"
    name = "pitch_3211"                   # optional label (default: the reader's)
    free_dofs = ["model_pitch"]           # reader options, passed to FlightRecord.read as keywords:
    airspeed = 20.0                       #   columns, free_dofs, airspeed (m/s), locked (rad), surface_kind, setup
    columns = { t = ["time_s", "s"], "q.model_pitch" = ["pitch", "deg"], "surfaces.hawk_elevator" = ["de", "deg"] }
    segment = [2.0, 38.0]                 # optional: keep t0 <= t <= t1, s
    smooth = 40                           # optional: smoothing span, samples (before resampling)
    resample = 100.0                      # optional: resample rate, Hz

Unknown keys are errors naming the key and the allowed ones.  :func:`run` writes ``DIR/report.md``
with its figures, ``DIR/identified.toml`` (the base file with the estimates tagged ``identified``) and
``DIR/identify.toml`` (a copy of the configuration); a fit that does not converge writes the report
but no parameter file.  None of these files is replaced without ``--overwrite``.
"""

from __future__ import annotations

import dataclasses
import math
import re
import shutil
import sys
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, TextIO

from rig_env.paths import check_out_folder
from rig_env.params import DEFAULT_FILE, JOINTS, PARAM_INDEX, RigParams
from rig_env.sysid.records import MIN_RECORD_SAMPLES, SURFACE_KINDS, FlightRecord  # MIN_RECORD_SAMPLES: what sysid.fit refuses below

METHODS = ("output_error", "filter_error", "equation_error")  # rig_env.sysid.fit.METHODS (kept here so parsing a config imports no model)
AERO_MODEL_NAMES = ("linear", "tables", "unsteady")  # rig_env.physics.pipeline.AERO_MODELS' names (a test keeps them equal)
TOP_KEYS = ("params", "method", "estimate", "options", "record")
OPTION_KEYS = ("max_iter", "tol", "aero_model")
ESTIMATE_KEYS = ("name", "start", "bounds")
READER_KEYS = ("columns", "free_dofs", "airspeed", "locked", "surface_kind", "setup")
RECORD_KEYS = ("path", "name", *READER_KEYS, "segment", "resample", "smooth")


class ConfigError(ValueError):
    """A bad ``rig identify`` configuration: the message names the key and what is allowed."""


@dataclass(frozen=True)
class RecordSpec:
    """One ``[[record]]``: the file, the reader's keyword options, and the pre-processing (s, Hz, samples)."""

    path: Path
    reader: Mapping[str, Any] = field(default_factory=dict)
    name: str | None = None
    segment: tuple[float, float] | None = None
    resample: float | None = None
    smooth: int | None = None
    where: str = "record"  # the configuration's "record[k]", for errors


@dataclass(frozen=True)
class IdentifyConfig:
    """A validated ``rig identify`` configuration (see the module docstring)."""

    source: Path
    params_file: Path
    method: str
    estimate: tuple[str, ...]
    start: Mapping[str, float]
    bounds: Mapping[str, tuple[float, float]]
    records: tuple[RecordSpec, ...]
    max_iter: int | None = None
    tol: float | None = None
    aero_model: str | None = None


def _unknown(where: str, got: Mapping[str, Any], allowed: tuple[str, ...]) -> None:
    bad = sorted(set(got) - set(allowed))
    if bad:
        raise ConfigError(f"{where}: unknown key(s) {bad}; allowed: {', '.join(allowed)}")


def _number(where: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ConfigError(f"{where} = {v!r}: must be a finite number")
    return float(v)


def _pair(where: str, v: Any) -> tuple[float, float]:
    if not isinstance(v, list) or len(v) != 2:
        raise ConfigError(f"{where} = {v!r}: must be a pair [low, high]")
    lo, hi = _number(where, v[0]), _number(where, v[1])
    if not lo < hi:
        raise ConfigError(f"{where} = {v!r}: needs low < high")
    return lo, hi


def _path(base: Path, where: str, v: Any) -> Path:
    if not isinstance(v, str) or not v:
        raise ConfigError(f"{where} = {v!r}: must be a file path (relative to the configuration's folder)")
    p = Path(v).expanduser()
    p = p if p.is_absolute() else base / p
    if not p.is_file():
        raise ConfigError(f"{where}: file not found: {p}")
    return p


def _estimate(raw: Any) -> tuple[tuple[str, ...], dict[str, float], dict[str, tuple[float, float]]]:
    if not isinstance(raw, list) or not raw:
        raise ConfigError("estimate: must be a non-empty list of dotted parameter names or { name, start, bounds } tables")
    names: list[str] = []
    start: dict[str, float] = {}
    bounds: dict[str, tuple[float, float]] = {}
    for k, item in enumerate(raw):
        where = f"estimate[{k}]"
        if isinstance(item, dict):
            _unknown(where, item, ESTIMATE_KEYS)
            if "name" not in item:
                raise ConfigError(f"{where}: needs name (a dotted parameter name)")
            name = item["name"]
        else:
            name, item = item, {}
        if not isinstance(name, str) or name not in PARAM_INDEX:
            raise ConfigError(f"{where}: unknown parameter {name!r}; valid names: rig_env.PARAM_NAMES (e.g. hawk_aero.CMalpha)")
        if name in names:
            raise ConfigError(f"{where}: {name} is listed twice")
        names.append(name)
        if "start" in item:
            start[name] = _number(f"{where}.start", item["start"])
        if "bounds" in item:
            bounds[name] = _pair(f"{where}.bounds", item["bounds"])
            if name in start and not bounds[name][0] <= start[name] <= bounds[name][1]:
                raise ConfigError(f"{where}: start = {start[name]} is outside bounds {list(bounds[name])}")
    return tuple(names), start, bounds


def _reader_options(where: str, raw: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key in READER_KEYS:
        if key not in raw:
            continue
        v, w = raw[key], f"{where}.{key}"
        if key == "columns":
            ok = isinstance(v, dict) and all(isinstance(b, list) and len(b) == 2 and all(isinstance(x, str) for x in b) for b in v.values())
            if not ok:
                raise ConfigError(f"{w}: must be a table of field = [\"column name\", \"unit\"] (fields: t, airspeed, "
                                  "\"q.<joint>\", \"qd.<joint>\", \"surfaces.<surface>\"; see rig_env.sysid.readers)")
            v = {a: (b[0], b[1]) for a, b in v.items()}
        elif key == "free_dofs":
            if not isinstance(v, list) or not v or any(j not in JOINTS for j in v):
                raise ConfigError(f"{w} = {v!r}: must be a non-empty list of joints from {list(JOINTS)}")
        elif key == "airspeed":  # m/s (a measured series comes through columns: airspeed = ["V", "m/s"])
            v = _number(w, v)
        elif key == "locked":
            if not isinstance(v, dict) or any(j not in JOINTS for j in v):
                raise ConfigError(f"{w}: must be a table joint = angle (rad), joints from {list(JOINTS)}")
            v = {j: _number(f"{w}.{j}", a) for j, a in v.items()}
            wide = [j for j, a in v.items() if abs(a) > 2.0 * math.pi]
            if wide:
                raise ConfigError(f"{w}.{wide[0]} = {v[wide[0]]:g}: a locked angle must lie within +-2 pi rad (+-360 deg); "
                                  "the angles are in rad")
        elif key == "surface_kind":
            if v not in SURFACE_KINDS:
                raise ConfigError(f"{w} = {v!r}: allowed: {', '.join(SURFACE_KINDS)}")
        elif key == "setup":
            if not isinstance(v, dict) or any(n not in PARAM_INDEX for n in v):
                bad = sorted(set(v) - set(PARAM_INDEX)) if isinstance(v, dict) else v
                raise ConfigError(f"{w}: must be a table of dotted parameter names = value; unknown: {bad}")
            v = {n: _number(f"{w}.{n}", a) for n, a in v.items()}
        out[key] = v
    return out


def _record(base: Path, k: int, raw: Any) -> RecordSpec:
    where = f"record[{k}]"
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: must be a table ([[record]])")
    _unknown(where, raw, RECORD_KEYS)
    if "path" not in raw:
        raise ConfigError(f"{where}: needs path (the record file)")
    name = raw.get("name")
    if name is not None and (not isinstance(name, str) or not name):
        raise ConfigError(f"{where}.name = {name!r}: must be a non-empty string")
    seg = None
    if "segment" in raw:
        seg = _pair(f"{where}.segment", raw["segment"])
    rate = None
    if "resample" in raw:
        rate = _number(f"{where}.resample", raw["resample"])
        if rate <= 0:
            raise ConfigError(f"{where}.resample = {rate}: must be a rate > 0 Hz")
    span = raw.get("smooth")
    if span is not None and (isinstance(span, bool) or not isinstance(span, int) or span < 3):
        raise ConfigError(f"{where}.smooth = {span!r}: must be an integer span >= 3 samples")
    return RecordSpec(_path(base, f"{where}.path", raw["path"]), _reader_options(where, raw), name, seg, rate, span, where)


def load_config(path: str | Path) -> IdentifyConfig:
    """Read and validate a ``rig identify`` configuration; ConfigError names the bad key."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            raw = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"configuration not found: {path}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    _unknown(str(path), raw, TOP_KEYS)
    base = path.resolve().parent
    params_file = _path(base, "params", raw["params"]) if "params" in raw else DEFAULT_FILE
    method = raw.get("method", "output_error")
    if method not in METHODS:
        raise ConfigError(f"method = {method!r}: allowed: {', '.join(METHODS)}")
    if "estimate" not in raw:
        raise ConfigError("estimate: missing; give the dotted names of the parameters to estimate")
    names, start, bounds = _estimate(raw["estimate"])
    opts = raw.get("options", {})
    if not isinstance(opts, dict):
        raise ConfigError("options: must be a table ([options])")
    _unknown("options", opts, OPTION_KEYS)
    max_iter = opts.get("max_iter")
    if max_iter is not None and (isinstance(max_iter, bool) or not isinstance(max_iter, int) or max_iter < 1):
        raise ConfigError(f"options.max_iter = {max_iter!r}: must be an integer >= 1")
    tol = None if "tol" not in opts else _number("options.tol", opts["tol"])
    if tol is not None and tol <= 0:
        raise ConfigError(f"options.tol = {tol}: must be > 0")
    aero_model = opts.get("aero_model")
    if aero_model is not None and aero_model not in AERO_MODEL_NAMES:
        raise ConfigError(f"options.aero_model = {aero_model!r}: allowed: {', '.join(AERO_MODEL_NAMES)}")
    if aero_model == "unsteady" and method == "equation_error":
        raise ConfigError("options.aero_model = 'unsteady' with method = 'equation_error': equation error regresses the measured "
                          "states, which hold no aerodynamic states; use output_error or filter_error")
    recs = raw.get("record")
    if not isinstance(recs, list) or not recs:
        raise ConfigError("record: give at least one [[record]] table with a path")
    records = tuple(_record(base, k, r) for k, r in enumerate(recs))
    return IdentifyConfig(path, params_file, method, names, start, bounds, records, max_iter, tol, aero_model)


def read_record(spec: RecordSpec) -> FlightRecord:
    """Read a record (``FlightRecord.read`` with the reader options) and pre-process it: segment, smooth, resample."""
    read = getattr(FlightRecord, "read", None)
    if read is None:
        raise ConfigError("FlightRecord.read is not available in this installation (the record readers)")
    rec = read(spec.path, **spec.reader)
    if spec.name is not None:
        rec = dataclasses.replace(rec, name=spec.name)
    if spec.segment is not None:
        rec = rec.segment(*spec.segment)
    if spec.smooth is not None:
        if spec.smooth > rec.t.size:  # lowess would clip it to the record: one fit over the whole record, not a smoothing
            raise ConfigError(f"{spec.where}.smooth = {spec.smooth}: more than the record's {rec.t.size} samples"
                              f"{' (after segment)' if spec.segment else ''}")
        rec = rec.smooth(spec.smooth)
    if spec.resample is not None:
        rec = rec.resample(spec.resample)
    if rec.t.size < MIN_RECORD_SAMPLES:
        raise ConfigError(f"{spec.where}: {rec.name} holds {rec.t.size} sample(s){' after segment and resample' if spec.segment or spec.resample else ''}; "
                          f"a record to fit needs at least {MIN_RECORD_SAMPLES}")
    return rec


def fit_kwargs(cfg: IdentifyConfig) -> dict[str, Any]:
    """The keyword arguments of ``rig_env.sysid.fit`` the configuration sets (beside records and params)."""
    kw: dict[str, Any] = {"estimate": list(cfg.estimate), "method": cfg.method}
    if cfg.bounds:
        kw["bounds"] = dict(cfg.bounds)
    if cfg.start:
        kw["start"] = dict(cfg.start)
    if cfg.max_iter is not None:
        kw["max_iter"] = cfg.max_iter
    if cfg.tol is not None:
        kw["tol"] = cfg.tol
    if cfg.aero_model is not None:
        kw["aero_model"] = cfg.aero_model
    return kw


STALE_SUFFIX = ".stale"
"""What an earlier run's ``identified.toml`` is renamed with when an ``--overwrite`` run's fit does not converge."""


def _refuse_existing(paths: list[Path], when: str = "") -> None:
    there = [str(p) for p in dict.fromkeys(paths) if p.exists()]
    if there:
        raise FileExistsError(f"{', '.join(there)} exist(s){when}; pass --overwrite to replace")


_FIGURE = re.compile(r"^(fit\d+_)?(correlation|cost|history_.+|acf_.+)\.png$")  # report.figure_name's forms


def earlier_figures(dest: Path) -> list[Path]:
    """The figures an earlier run's ``report.md`` in ``dest`` shows (its image links to files in ``dest`` named
    as the report names its figures): what an ``--overwrite`` run removes when it does not write them itself."""
    try:
        text = (dest / "report.md").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return []
    links = re.findall(r"!\[[^\]]*\]\(([^)/\\]+)\)", text)
    return [dest / n for n in dict.fromkeys(links) if _FIGURE.match(n)]


def run(config: str | Path, out_dir: str | Path, *, overwrite: bool = False, stream: TextIO | None = None,
        progress: TextIO | None = None) -> dict[str, Path]:
    """``rig identify``: read the records, fit, write the report and the identified parameter file.

    stream: where the summary goes (default stdout); progress: where the fit's per-iteration lines go
    (default stderr).  Returns the written files by kind.  Raises ConfigError (a ValueError) for a bad
    configuration or record or an ``--out`` that is (or lies under) a file, FileExistsError for outputs
    already there, RuntimeError for a fit that failed or did not converge.

    Without ``overwrite`` no file is replaced: ``report.md``, every figure the report will write
    (``cost.png``, ``correlation.png``, ``history_<record>.png``, ``acf_<record>.png``), ``identified.toml``
    and ``identify.toml`` are checked before the fit (the figures' names from the configuration and the
    records read) and again after it, before anything is written (the fit's records name the figures).

    With ``overwrite``, the figures an earlier report in the folder showed and this one does not (a record fewer)
    are removed (:func:`earlier_figures`; other files are never touched); a fit that does not converge writes the report and ``identify.toml`` but no
    parameter file; an ``identified.toml`` already in the folder (an earlier run's, of another fit) is then
    renamed ``identified.toml.stale`` (replacing an earlier ``.stale``), so the folder never pairs this
    report with another fit's parameters and the earlier file is kept; the error line says so.
    """
    import rig_env.sysid as sysid
    from rig_env.sysid.paramfile import save_fit_params
    from rig_env.sysid.report import figure_names, report_files, write_report

    out = stream if stream is not None else sys.stdout
    prog = progress if progress is not None else sys.stderr
    cfg = load_config(config)
    dest = check_out_folder("--out", out_dir)
    targets = {"report": dest / "report.md", "params": dest / "identified.toml", "config": dest / "identify.toml"}
    known = [dest / n for n in figure_names(len(cfg.estimate), [s.name for s in cfg.records if s.name is not None])]
    if not overwrite:  # what the configuration names: refused before reading the records
        _refuse_existing([*targets.values(), *known])
    params = RigParams.from_toml(cfg.params_file)
    records = []
    for spec in cfg.records:
        out.write(f"reading {spec.path}\n")
        records.append(read_record(spec))
    if not overwrite:  # every figure's name, the records' names now known
        _refuse_existing([*targets.values(), *(dest / n for n in figure_names(len(cfg.estimate), [r.name for r in records]))])
    fit = sysid.fit
    def report_progress(line: str) -> None:
        prog.write(f"  {line}\n")
        prog.flush()

    out.write(f"fitting {len(cfg.estimate)} parameters by {cfg.method} to {len(records)} record(s)\n")
    out.flush()
    try:
        with warnings.catch_warnings():  # a misfit is told below, once, with the report's name
            warnings.simplefilter("ignore", sysid.FitWarning)
            result = fit(records, params, progress=report_progress, **fit_kwargs(cfg))
    except (ValueError, RuntimeError, ArithmeticError) as exc:
        raise RuntimeError(f"the fit failed: {exc}") from exc
    if not overwrite:  # the fit's own records name the figures: checked again before writing anything
        _refuse_existing([*targets.values(), *report_files(result, dest)], " (the fit ran; nothing was written)")
    dest = check_out_folder("--out", dest)  # still a folder
    dest.mkdir(parents=True, exist_ok=True)
    stale = None
    if not result.converged and targets["params"].exists():  # only with overwrite: an earlier run's parameters, kept aside
        stale = targets["params"].replace(targets["params"].with_name(targets["params"].name + STALE_SUFFIX))
        out.write(f"moved the earlier {targets['params']} (another fit's) to {stale}\n")
    earlier = earlier_figures(dest) if overwrite else []
    written = {"report": write_report(result, dest, title=f"System identification: {cfg.source.name}", overwrite=overwrite)}
    gone = [f for f in earlier if f not in set(report_files(result, dest)) and f.is_file()]
    for f in gone:  # the earlier run's own figures this report does not show (a record fewer): not left to be taken for this run's
        f.unlink()
    if gone:
        out.write(f"removed the earlier run's {', '.join(f.name for f in gone)} (not in this report)\n")
    if not (targets["config"].exists() and targets["config"].samefile(cfg.source)):
        shutil.copyfile(cfg.source, targets["config"])
    written["config"] = targets["config"]
    out.write(f"wrote {written['report']} and its figures\n")
    for w in result.warnings:
        out.write(f"warning: {w}\n")
    if not result.converged:
        moved = f" (the earlier {targets['params'].name}, of another fit, is now {stale})" if stale is not None else ""
        raise RuntimeError(f"the fit did not converge ({result.message or 'no message'}) after {result.iterations} iterations; "
                           f"see {written['report']}; no parameter file written{moved}")
    written["params"] = save_fit_params(result, targets["params"], base_file=cfg.params_file, overwrite=overwrite)
    out.write(f"wrote {written['params']} (fly it: rig compare --params {written['params']})\n")
    out.flush()
    return written
