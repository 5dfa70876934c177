"""Reading and writing :class:`~rig_env.sysid.records.FlightRecord` files: CSV, ``.npz``, MATLAB ``.mat``, frame logs.

**The project's own layout** (what :meth:`FlightRecord.write` writes and :meth:`FlightRecord.read` reads
without a column map): one column per signal, named with its unit,

| column | unit | present |
|---|---|---|
| ``t_s`` | s | always |
| ``q_<joint>_rad`` | rad | per free joint (``rig_env.JOINTS`` names) |
| ``qd_<joint>_rad_s`` | rad/s | per free joint, when rates were measured |
| ``surface_<surface>_deg`` | deg | per recorded surface (``rig_env.SURFACES`` names) |
| ``airspeed_m_s`` | m/s | when the tunnel speed is a series |

and the metadata (``format``: ``"rig-flight-record"``, ``version``, ``name``, ``free_dofs``, ``locked``
(rad), ``surface_kind``, ``setup``, ``airspeed`` (m/s, or null for a series) and ``columns``, the column
map below) as one JSON document: in CSV the first line ``# rig-flight-record {...}`` above the header
row; in ``.npz`` the string array ``rig_flight_record``; in ``.mat`` (MATLAB v5, scipy.io) the char
variable ``rig_flight_record``, the columns as column vectors.  CSV values are written with 17
significant digits, so every format round-trips float64 exactly.

**Foreign files** need a column map, ``{field: (column, unit)}``, and the configuration as keywords::

    FlightRecord.read("run.csv", columns={"t": ("time", "ms"), "q.model_pitch": ("theta", "deg"),
                      "surfaces.hawk_elevator": ("de_cmd", "deg"), "airspeed": ("V", "m/s")},
                      surface_kind="commanded")

| field | allowed units |
|---|---|
| ``t`` | s, ms |
| ``q.<joint>`` | rad, deg |
| ``qd.<joint>`` | rad/s, deg/s |
| ``surfaces.<surface>`` | deg, rad |
| ``airspeed`` | m/s |

CSV: optional ``#`` comment lines, one header row of column names, comma-separated numbers.  ``.npz``
and ``.mat``: one array per column; ``"name[k]"`` selects column k (from 0) of a 2-D array.  The free
joints are those mapped to ``q.<joint>`` (a ``free_dofs`` keyword must agree); ``airspeed=`` (m/s)
is required when no airspeed column is mapped and ``surface_kind=`` when surfaces are.

**Frame logs** of the real-time loop (:mod:`rig_env.framelog_format`, recognised by their header line):
see :func:`read_frame_log`.

Every problem raises :class:`~rig_env.sysid.records.RecordError` naming the file, the field or column
and what is allowed; readers also apply :func:`~rig_env.sysid.records.check_sampling` (gaps).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from rig_env.framelog_format import FORMAT as LOG_FORMAT
from rig_env.framelog_format import read_log
from rig_env.params import JOINTS, SURFACES
from rig_env.sysid.checks import RecordError, check_sampling, is_number

if TYPE_CHECKING:
    from rig_env.sysid.records import FlightRecord

ColumnMap = Mapping[str, tuple[str, str]]
"""``{field: (column name, unit)}``; fields ``t``, ``q.<joint>``, ``qd.<joint>``, ``surfaces.<surface>``, ``airspeed``."""

FORMAT = "rig-flight-record"
VERSION = 1
META_KEY = "rig_flight_record"
SUFFIXES = (".csv", ".npz", ".mat")

# unit -> factor to the record's unit, per field kind
UNITS: dict[str, dict[str, float]] = {
    "t": {"s": 1.0, "ms": 1e-3},
    "q": {"rad": 1.0, "deg": math.pi / 180.0},
    "qd": {"rad/s": 1.0, "deg/s": math.pi / 180.0},
    "surfaces": {"deg": 1.0, "rad": 180.0 / math.pi},
    "airspeed": {"m/s": 1.0},
}
KIND_NAMES = {"t": "time", "q": "angles", "qd": "rates", "surfaces": "surface deflections", "airspeed": "airspeed"}
_SELECT = re.compile(r"^(?P<name>.+)\[(?P<k>\d+)\]$")


# ---------------------------------------------------------------------------------------------- column maps
def field_kind(field: str) -> str:
    """``"t"``, ``"q"``, ``"qd"``, ``"surfaces"`` or ``"airspeed"`` of a column-map field; RecordError if unknown."""
    if field in ("t", "airspeed"):
        return field
    kind, _, name = field.partition(".")
    if kind in ("q", "qd") and name in JOINTS:
        return kind
    if kind == "surfaces" and name in SURFACES:
        return kind
    raise RecordError(f"columns: unknown field {field!r}; fields: 't', 'airspeed', 'q.<joint>', 'qd.<joint>' with joints {list(JOINTS)}, "
                      f"'surfaces.<surface>' with surfaces {list(SURFACES)}")


def check_column_map(columns: ColumnMap) -> dict[str, tuple[str, str, float]]:
    """Validated map: ``{field: (column, unit, factor to the record's unit)}``."""
    if not isinstance(columns, Mapping):
        raise RecordError(f"columns: a mapping {{field: (column, unit)}}, got {type(columns).__name__}")
    out: dict[str, tuple[str, str, float]] = {}
    for fld, spec in columns.items():
        kind = field_kind(fld)
        if not (isinstance(spec, Sequence) and not isinstance(spec, str) and len(spec) == 2 and all(isinstance(s, str) for s in spec)):
            raise RecordError(f"columns[{fld!r}] = {spec!r}: give (column name, unit)")
        col, unit = spec
        allowed = UNITS[kind]
        if unit not in allowed:
            raise RecordError(f"columns[{fld!r}]: unit {unit!r} is not allowed for {KIND_NAMES[kind]}; allowed: {', '.join(allowed)}")
        out[fld] = (col, unit, allowed[unit])
    if "t" not in out:
        raise RecordError("columns: no column for 't' (time, s or ms)")
    if not any(f.startswith("q.") for f in out):
        raise RecordError(f"columns: no angle column (q.<joint>); map one per free joint of {list(JOINTS)}")
    return out


def _joint_names(label: str, v: object) -> tuple[str, ...]:
    """A ``free_dofs`` keyword (a joint name or a sequence of them) as a tuple; RecordError naming ``label`` otherwise."""
    names = (v,) if isinstance(v, str) else tuple(v) if isinstance(v, (Sequence, np.ndarray)) else None
    if names is None or not all(isinstance(j, str) for j in names):
        raise RecordError(f"{label} = {v!r}: give a list of joint names of {list(JOINTS)}")
    return names


def own_columns(record: FlightRecord) -> dict[str, tuple[str, str]]:
    """The project's own column map of ``record`` (see the module table)."""
    cols = {"t": ("t_s", "s")}
    cols.update({f"q.{j}": (f"q_{j}_rad", "rad") for j in record.free_dofs})
    if record.qd is not None:
        cols.update({f"qd.{j}": (f"qd_{j}_rad_s", "rad/s") for j in record.free_dofs})
    cols.update({f"surfaces.{s}": (f"surface_{s}_deg", "deg") for s in SURFACES if s in record.surfaces})
    if np.ndim(record.airspeed) == 1:
        cols["airspeed"] = ("airspeed_m_s", "m/s")
    return cols


def _values(record: FlightRecord, fld: str) -> np.ndarray:
    """The record's series of a field, in the record's units."""
    kind, _, name = fld.partition(".")
    if fld == "t":
        return record.t
    if fld == "airspeed":
        return record.airspeed_series()
    if kind == "surfaces":
        return record.surfaces[name]
    k = record.free_dofs.index(name)
    return (record.q if kind == "q" else record.qd)[:, k]  # type: ignore[index]


def _meta(record: FlightRecord, columns: Mapping[str, tuple[str, str]]) -> str:
    return json.dumps({
        "format": FORMAT, "version": VERSION, "name": record.name, "free_dofs": list(record.free_dofs), "locked": dict(record.locked or {}),
        "surface_kind": record.surface_kind, "setup": dict(record.setup),
        "airspeed": float(record.airspeed) if np.ndim(record.airspeed) == 0 else None,
        "columns": {k: list(v) for k, v in columns.items()},
    })


# ---------------------------------------------------------------------------------------------- write
def write(record: FlightRecord, path: str | os.PathLike, overwrite: bool = False) -> Path:
    """Write ``record`` in the project's layout; the format follows the suffix (.csv, .npz, .mat).

    An existing file is an error unless ``overwrite``.  Returns the path written.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in SUFFIXES:
        raise RecordError(f"{p}: cannot write {suffix or 'a file without suffix'!r}; allowed suffixes: {', '.join(SUFFIXES)}")
    cols = own_columns(record)
    data = {col: _values(record, fld) for fld, (col, _u) in cols.items()}
    meta = _meta(record, cols)
    try:
        with open(p, "wb" if overwrite else "xb") as f:
            if suffix == ".csv":
                text = io.StringIO()
                text.write(f"# {FORMAT} {meta}\n")
                text.write(",".join(data) + "\n")
                np.savetxt(text, np.column_stack(list(data.values())), fmt="%.17g", delimiter=",")
                f.write(text.getvalue().encode("utf-8"))
            elif suffix == ".npz":
                np.savez(f, **data, **{META_KEY: np.array(meta)})
            else:
                from scipy.io import savemat

                savemat(f, {**data, META_KEY: meta}, format="5", oned_as="column")
    except FileExistsError:
        raise RecordError(f"{p}: exists; pass overwrite=True to replace it") from None
    except OSError as e:
        raise RecordError(f"{p}: cannot write: {e.strerror or e}") from None
    return p


# ---------------------------------------------------------------------------------------------- read
def detect(path: str | os.PathLike) -> str:
    """``"csv"``, ``"npz"``, ``"mat"`` or ``"log"`` from the file's first bytes (and, for CSV, its suffix)."""
    p = Path(path)
    if not p.exists():
        raise RecordError(f"{p}: no such file")
    if not p.is_file():
        raise RecordError(f"{p}: not a file")
    try:
        with open(p, "rb") as f:
            head = f.read(512)
    except OSError as e:
        raise RecordError(f"{p}: cannot read: {e.strerror or e}") from None
    if head.startswith((b"PK\x03\x04", b"PK\x05\x06")):
        return "npz"
    if head.startswith(b"MATLAB 7.3"):
        raise RecordError(f"{p}: a MATLAB v7.3 (HDF5) file; save it with save(..., '-v7') (MATLAB v5 format, which scipy.io reads)")
    if head.startswith(b"MATLAB"):
        return "mat"
    if head.startswith(b"{") and _log_header(p) is not None:
        return "log"
    if p.suffix.lower() in SUFFIXES:  # not what its first bytes say: the reader of its suffix reports why
        return p.suffix.lower()[1:]
    raise RecordError(f"{p}: unknown format; readable: CSV (.csv), NumPy .npz, MATLAB v5 .mat, the loop's frame log ({LOG_FORMAT})")


def _log_header(p: Path) -> dict[str, Any] | None:
    with open(p, "rb") as f:
        line = f.readline(1 << 20)
    try:
        h = json.loads(line)
    except ValueError:
        return None
    return h if isinstance(h, dict) and h.get("format") == LOG_FORMAT else None


def read_fields(path: str | os.PathLike, columns: ColumnMap | None = None, *, free_dofs: Sequence[str] | None = None,
                locked: Mapping[str, float] | None = None, surface_kind: str | None = None, airspeed: float | None = None,
                setup: Mapping[str, float] | None = None, name: str | None = None, allow_gaps: bool = False) -> dict[str, Any]:
    """The fields (``FlightRecord(**fields)``, which :meth:`FlightRecord.read` builds) of a record from a file (see the module docstring): own layout, a foreign file with ``columns``, or a frame log.

    Keywords give (foreign files) or replace (own layout, frame logs) the configuration: ``free_dofs``,
    ``locked`` ({joint: rad}), ``surface_kind``, ``airspeed`` (m/s, constant; not with an airspeed column),
    ``setup``, ``name``.  ``allow_gaps``: accept sample intervals over the gap bound of
    :func:`~rig_env.sysid.records.check_sampling`.
    """
    p = Path(path)
    kind = detect(p)
    if kind == "log":
        if columns is not None:
            raise RecordError(f"{p}: a frame log has a fixed layout; columns= is for CSV, .npz and .mat files")
        if airspeed is not None:
            raise RecordError(f"{p}: a frame log carries the measured airspeed series; airspeed= is for files without one")
        return frame_log_fields(p, free_dofs=free_dofs, locked=locked, surface_kind=surface_kind or "commanded", setup=setup, name=name,
                                allow_gaps=allow_gaps)
    meta, data = {"csv": _read_csv, "npz": _read_npz, "mat": _read_mat}[kind](p)
    config: dict[str, Any] = {}
    if columns is None:
        if meta is None:
            raise RecordError(f"{p}: no {FORMAT} metadata (a file from elsewhere): give a column map columns={{field: (column, unit)}} "
                              f"and the configuration (airspeed=, surface_kind=, ...); columns present: {sorted(data)}")
        columns = {k: tuple(v) for k, v in meta["columns"].items()}  # type: ignore[misc]
        config = {k: meta[k] for k in ("name", "locked", "surface_kind", "setup", "airspeed")}
        try:
            cmap = check_column_map(columns)
        except RecordError as e:
            raise RecordError(f"{p}: {FORMAT} metadata: {e}") from None
    else:
        cmap = check_column_map(columns)
    given = {"locked": locked, "surface_kind": surface_kind, "setup": setup, "name": name, "airspeed": airspeed}
    config.update({k: v for k, v in given.items() if v is not None})
    return _build(p, data, cmap, config, free_dofs, allow_gaps)


def _build(p: Path, data: dict[str, np.ndarray], cmap: dict[str, tuple[str, str, float]], config: dict[str, Any],
           free_dofs: Sequence[str] | None, allow_gaps: bool) -> dict[str, Any]:
    series: dict[str, np.ndarray] = {}
    for fld, (col, _unit, factor) in cmap.items():
        series[fld] = _column(p, data, col, fld) * factor
    t = series["t"]
    for fld, v in series.items():
        col = cmap[fld][0]
        if v.size != t.size:
            raise RecordError(f"{p}: column {col!r} ({fld}) has {v.size} samples; the time column {cmap['t'][0]!r} has {t.size}")
        bad = ~np.isfinite(v)
        if bad.any():
            k = int(np.argmax(bad))
            raise RecordError(f"{p}: column {col!r} ({fld}): {int(bad.sum())} non-finite or empty value(s), the first at row {k}"
                              + (f" (t = {t[k]:.6g} s)" if fld != "t" and np.isfinite(t[k]) else ""))
    dt = np.diff(t)
    if np.any(dt <= 0.0):
        k = int(np.argmax(dt <= 0.0))
        raise RecordError(f"{p}: time column {cmap['t'][0]!r} must be strictly increasing; row {k + 1} ({t[k + 1]:.6g} s) follows "
                          f"row {k} ({t[k]:.6g} s)")
    label = str(config.get("name") or p.stem)
    check_sampling(t, f"{p}: time column {cmap['t'][0]!r}", allow_gaps)
    free = [f.partition(".")[2] for f in cmap if f.startswith("q.")]
    if free_dofs is not None:
        given = _joint_names(f"{p}: free_dofs", free_dofs)
        if set(given) != set(free):
            raise RecordError(f"{p}: free_dofs = {list(given)} but the angle columns are for {free}; map q.<joint> for each free joint")
    rate_joints = [f.partition(".")[2] for f in cmap if f.startswith("qd.")]
    if rate_joints and set(rate_joints) != set(free):
        raise RecordError(f"{p}: rate columns (qd.<joint>) for {rate_joints} but the free joints are {free}; map all or none")
    surfaces = {f.partition(".")[2]: v for f, v in series.items() if f.startswith("surfaces.")}
    if "airspeed" in series:
        if config.get("airspeed") is not None:
            raise RecordError(f"{p}: airspeed = {config['airspeed']} m/s given and column {cmap['airspeed'][0]!r} mapped to airspeed; give one")
        air: float | np.ndarray = series["airspeed"]
    elif config.get("airspeed") is not None:
        air = config["airspeed"]  # checked by the record (a number in the allowed range)
    else:
        raise RecordError(f"{p}: no airspeed column mapped; give the tunnel speed as airspeed= (m/s, 0 for wind off) or map 'airspeed'")
    if surfaces and config.get("surface_kind") is None:
        raise RecordError(f"{p}: surface columns given: say what they are, surface_kind='commanded' (sent to the servos) or 'actual' (deflections)")
    return dict(
        t=t, free_dofs=tuple(free), q=np.column_stack([series[f"q.{j}"] for j in free]),
        qd=np.column_stack([series[f"qd.{j}"] for j in free]) if rate_joints else None,
        surfaces=surfaces, airspeed=air, locked=config.get("locked"), surface_kind=config.get("surface_kind") or "commanded",
        setup=config.get("setup") or {}, name=label,
    )


def _column(p: Path, data: dict[str, np.ndarray], col: str, fld: str) -> np.ndarray:
    """1-D float column ``col`` (or ``name[k]``: column k of a 2-D array)."""
    m = _SELECT.match(col)
    base, k = (m["name"], int(m["k"])) if m and col not in data else (col, None)
    if base not in data:
        raise RecordError(f"{p}: column {col!r} (for {fld}) is not in the file; columns present: {sorted(data)}")
    a = data[base]
    if k is not None:
        if a.ndim != 2 or k >= a.shape[1]:
            raise RecordError(f"{p}: {col!r} (for {fld}): {base!r} has shape {a.shape}; [k] selects column k of a 2-D array")
        a = a[:, k]
    if a.ndim != 1:
        raise RecordError(f"{p}: column {col!r} (for {fld}) has shape {a.shape}; expected a vector (select a column of a matrix as 'name[k]')")
    if np.iscomplexobj(a):
        raise RecordError(f"{p}: column {col!r} (for {fld}) holds complex ({a.dtype}) values; a record's columns are real numbers")
    if not (np.issubdtype(a.dtype, np.number) or a.dtype == bool):
        raise RecordError(f"{p}: column {col!r} (for {fld}) holds {a.dtype} values, not numbers")
    return a.astype(np.float64)


def _parse_meta(p: Path, text: str) -> dict[str, Any]:
    try:
        meta = json.loads(text)
    except ValueError as e:
        raise RecordError(f"{p}: unreadable {FORMAT} metadata: {e}") from None
    keys = ("format", "version", "name", "free_dofs", "locked", "surface_kind", "setup", "airspeed", "columns")
    if not isinstance(meta, dict) or any(k not in meta for k in keys) or meta["format"] != FORMAT:
        raise RecordError(f"{p}: {FORMAT} metadata must be a JSON object with keys {list(keys)}")
    if meta["version"] != VERSION:
        raise RecordError(f"{p}: {FORMAT} version {meta['version']!r}; this reader reads version {VERSION}")
    kinds = {  # what each entry must be (a hand-edited file): the values themselves are the record's to check
        "name": (lambda v: isinstance(v, str), "a string"),
        "free_dofs": (lambda v: isinstance(v, list) and all(isinstance(j, str) for j in v), "a list of joint names"),
        "locked": (lambda v: v is None or isinstance(v, dict), "an object {joint: rad} or null"),
        "surface_kind": (lambda v: isinstance(v, str), "a string"),
        "setup": (lambda v: isinstance(v, dict), "an object {dotted parameter name: value}"),
        "airspeed": (lambda v: v is None or is_number(v), "a number (m/s) or null (a series)"),
        "columns": (lambda v: isinstance(v, dict) and all(isinstance(c, list) for c in v.values()),
                    "an object {field: [column, unit]}"),
    }
    for k, (ok, what) in kinds.items():
        if not ok(meta[k]):
            raise RecordError(f"{p}: {FORMAT} metadata: {k} = {json.dumps(meta[k])}: must be {what}")
    return meta


def _read_csv(p: Path) -> tuple[dict[str, Any] | None, dict[str, np.ndarray]]:
    try:
        text = p.read_text(encoding="utf-8-sig")  # a byte-order mark (Excel's "CSV UTF-8") is not part of the first name
    except (UnicodeDecodeError, OSError) as e:
        raise RecordError(f"{p}: cannot read as UTF-8 CSV text: {e}") from None
    meta = None
    lines = text.splitlines()
    body: list[tuple[int, str]] = []
    for i, line in enumerate(lines):
        if line.startswith("#"):
            if line.startswith(f"# {FORMAT} "):
                meta = _parse_meta(p, line[len(FORMAT) + 3 :])
            continue
        if line.strip():
            body.append((i + 1, line))
    if not body:
        raise RecordError(f"{p}: no header row (column names) and no data")
    rows = list(csv.reader([line for _, line in body], skipinitialspace=True))
    names = [c.strip() for c in rows[0]]
    dupes = sorted({c for c in names if names.count(c) > 1})
    if dupes or not all(names):
        raise RecordError(f"{p}: header row (line {body[0][0]}): column names must be non-empty and distinct; repeated: {dupes}")
    for (lineno, _), r in zip(body[1:], rows[1:]):
        if len(r) != len(names):
            raise RecordError(f"{p}: line {lineno} has {len(r)} fields; the header row has {len(names)} columns")
    cells = np.array(rows[1:], dtype=str).reshape(len(rows) - 1, len(names))
    data: dict[str, np.ndarray] = {}
    for j, c in enumerate(names):
        col = np.char.strip(cells[:, j])
        col = np.where(col == "", "nan", col)
        try:
            data[c] = col.astype(np.float64)
        except ValueError:
            k = next(k for k, v in enumerate(col) if not _is_float(v))
            raise RecordError(f"{p}: column {c!r}, line {body[k + 1][0]}: {str(col[k])!r} is not a number") from None
    return meta, data


def _is_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _read_npz(p: Path) -> tuple[dict[str, Any] | None, dict[str, np.ndarray]]:
    try:
        with np.load(p, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except Exception as e:  # noqa: BLE001 - zipfile.BadZipFile, pickled objects refused, truncated data: an unreadable file
        raise RecordError(f"{p}: cannot read as .npz: {type(e).__name__}: {e}") from None
    meta = _parse_meta(p, str(data.pop(META_KEY))) if META_KEY in data else None
    return meta, data


def _read_mat(p: Path) -> tuple[dict[str, Any] | None, dict[str, np.ndarray]]:
    from scipy.io import loadmat

    try:
        raw = loadmat(p, squeeze_me=False, chars_as_strings=True)
    except Exception as e:  # noqa: BLE001 - scipy raises several types for a damaged file
        raise RecordError(f"{p}: cannot read as MATLAB v5 .mat: {type(e).__name__}: {e}") from None
    data: dict[str, np.ndarray] = {}
    meta = None
    for k, v in raw.items():
        if k.startswith("__"):
            continue
        if k == META_KEY:
            meta = _parse_meta(p, str(np.asarray(v).ravel()[0]))
            continue
        a = np.asarray(v)
        if a.ndim == 2 and 1 in a.shape and a.size > 1:
            a = a.ravel()  # MATLAB keeps vectors as (n, 1) or (1, n)
        data[k] = a
    return meta, data


# ---------------------------------------------------------------------------------------------- frame logs
def frame_log_fields(path: str | os.PathLike, *, free_dofs: Sequence[str] | None = None, locked: Mapping[str, float] | None = None,
                     surface_kind: str = "commanded", setup: Mapping[str, float] | None = None, name: str | None = None,
                     allow_gaps: bool = False) -> dict[str, Any]:
    """The fields of a record from the real-time loop's frame log (``rig_env.sysid.read_frame_log`` builds it): one sample per fresh sensor frame.

    Samples: the ticks with ``fresh = 1``, each sensor frame once (first use of its ``seq``); ``t`` = the
    frame's ``rig_time`` (s); ``q`` = its angles of the free joints (rad); ``airspeed`` = the measured series
    (m/s); no rates (``qd`` None: the rig sends angles only).  ``free_dofs``: from the header (logs written
    since it carries them), else this keyword is required; when both, they must agree.  ``locked``: by
    default the mean reading of each locked joint (rad).

    Surfaces (deg, ``surface_kind="commanded"``, all six ``rig_env.SURFACES``): the ``command`` logged on
    the frame's tick, i.e. the command the loop sent after reading that frame.  The rig applies it from
    its next tick until the next command, so sample k's command acts over ``[t_k, t_k+1)``: the
    zero-order hold of :meth:`FlightRecord.surface_schedules` and of ``rig_env.simulate`` (the simulated
    rig steps its physics from frame k with exactly that command).  On the real rig it acts after the
    loop's latency (``send - deadline``, a few ms), a delay left to the servo model.  Commands sent on
    ticks without a new frame (a lost frame) are not in the record: its samples are frames, and the gap
    check (``allow_gaps``) reports the missing frames.  Frames of every loop state are kept (DISARMED and
    FAULT ticks with the neutral commands actually sent): :meth:`FlightRecord.segment` selects the armed part.
    """
    p = Path(path)
    if not p.exists():
        raise RecordError(f"{p}: no such file")
    try:
        header, recs = read_log(p)
    except (OSError, ValueError) as e:
        raise RecordError(f"{p}: cannot read as a frame log: {e}") from None
    names = recs.dtype.names or ()
    missing = [f for f in ("fresh", "seq", "rig_time", "angles", "airspeed", "command") if f not in names]
    if missing:
        raise RecordError(f"{p}: frame log without field(s) {missing}; fields present: {list(names)}")
    stored = header.get("free_dofs")
    if stored is not None and not (isinstance(stored, list) and all(isinstance(j, str) for j in stored)):
        raise RecordError(f"{p}: the log's header has free_dofs = {json.dumps(stored)}; expected a list of joint names of {list(JOINTS)}")
    if free_dofs is None and stored is None:
        raise RecordError(f"{p}: the log's header does not name the free joints (written before free_dofs was logged); give free_dofs= "
                          f"(names of {list(JOINTS)})")
    free_given = None if free_dofs is None else _joint_names(f"{p}: free_dofs", free_dofs)
    if free_given is not None and stored is not None and set(free_given) != set(stored):
        raise RecordError(f"{p}: free_dofs = {list(free_given)} but the log's header says {list(stored)}")
    free = tuple(free_given if free_given is not None else stored)
    unknown = [j for j in free if j not in JOINTS]
    if unknown:
        raise RecordError(f"{p}: free_dofs: unknown joint(s) {unknown}; valid names: {list(JOINTS)}")
    fresh = recs[(recs["fresh"] == 1) & (recs["seq"] >= 0)]
    _, first = np.unique(fresh["seq"], return_index=True)
    frames = fresh[np.sort(first)]
    if frames.size < 2:
        raise RecordError(f"{p}: {frames.size} fresh sensor frame(s) in {recs.size} ticks; a record needs at least 2")
    t = frames["rig_time"].astype(np.float64)
    dt = np.diff(t)
    if np.any(dt <= 0.0):
        k = int(np.argmax(dt <= 0.0))
        raise RecordError(f"{p}: rig_time must increase from frame to frame; frame seq {int(frames['seq'][k + 1])} at {t[k + 1]:.6g} s "
                          f"follows seq {int(frames['seq'][k])} at {t[k]:.6g} s (a restarted rig? segment the log)")
    label = name or p.stem
    check_sampling(t, f"{p}: rig_time of the fresh frames", allow_gaps)
    angles = frames["angles"].astype(np.float64)
    idx = [JOINTS.index(j) for j in free]
    if locked is None:
        locked = {j: float(np.mean(angles[:, k])) for k, j in enumerate(JOINTS) if j not in free}
    cmd = np.degrees(frames["command"].astype(np.float64))
    return dict(
        t=t, free_dofs=free, q=angles[:, idx], surfaces={s: cmd[:, k] for k, s in enumerate(SURFACES)},
        airspeed=frames["airspeed"].astype(np.float64), locked=locked, surface_kind=surface_kind, setup=setup or {}, name=label,
    )
