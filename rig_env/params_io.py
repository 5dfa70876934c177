"""The text of a parameter file: a tree of frozen parameter dataclasses written as TOML, one copy of the format.

The lowest layer of ``rig_env`` (imports no other module of the project), so that both
:meth:`rig_env.params.RigParams.to_toml` and :mod:`rig_env.sysid.paramfile` (identified values) write
through it.  Layout as ``rig_env/data/default_rig.toml``: a ``[group]`` table per dataclass of leaves,
each leaf ``name = { value = ..., source = ..., unit = ..., note = ..., std/records/method }``, then the
``[high_incidence]`` tables (``source``, ``note`` and one float array per field).
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence


class ParameterError(ValueError):
    """Invalid rig parameter: the message names the field and its allowed range."""


IDENTIFIED_KEYS = ("std", "records", "method")
"""Keys an ``identified`` entry carries besides value, source, note and unit (and no other source may)."""

IDENTIFICATION_METHODS = ("output_error", "filter_error", "equation_error")
"""The ``method`` an ``identified`` entry may name, and the fitting methods :data:`rig_env.sysid.METHODS` (the one
list: it lives in the file format's lowest layer because the parameters may not import the identification package,
by the import contracts of pyproject.toml)."""

Provenance = Callable[[str], Mapping[str, Any]]
"""A dotted name (or ``"high_incidence"``) -> its ``source``, ``note`` and, if identified, ``std``, ``records``, ``method``."""


def did_you_mean(name: str, names: Sequence[str], cutoff: float = 0.75) -> str:
    """" (did you mean 'a' or 'b'?)" for the (up to three) names closest to a misspelt ``name``, "" when none
    is close: the hint an unknown-name error carries instead of a list of every valid name.  ``cutoff``: the least
    similarity (difflib's ratio) of a hint; 0.75 suits the long dotted parameter names, short names (a law kind of
    three letters, one of them wrong: 0.67) want difflib's default 0.6."""
    lower = {n.lower(): n for n in names}  # the tables' case (CLa, Cnb) is the kind of thing misspelt
    close = [lower[c] for c in difflib.get_close_matches(name.lower(), list(lower), n=3, cutoff=cutoff)]
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


def toml_value(v: Any) -> str:
    """A TOML literal of a bool, int, finite float, string or list of them; ParameterError otherwise."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ParameterError(f"cannot write the non-finite value {v!r}")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # a TOML basic string: JSON's escapes are TOML's
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise ParameterError(f"cannot write {type(v).__name__} {v!r} to a parameter file")


def _entry(value: Any, unit: str, prov: Mapping[str, Any]) -> str:
    items = [("value", value), ("source", prov["source"]), ("unit", unit)]
    if prov.get("note"):
        items.append(("note", prov["note"]))
    for k in IDENTIFIED_KEYS:
        if k in prov:
            items.append((k, prov[k]))
    return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in items) + " }"


def _group(obj: Any, prefix: str, provenance: Provenance, override: Mapping[str, tuple[Any, Mapping[str, Any]]], lines: list[str]) -> None:
    leaves, subs = [], []
    for f in dataclasses.fields(obj):
        (subs if dataclasses.is_dataclass(getattr(obj, f.name)) else leaves).append(f)
    if leaves:
        lines += ["", f"[{prefix}]"]
        for f in leaves:
            name = f"{prefix}.{f.name}"
            value, prov = override[name] if name in override else (getattr(obj, f.name), provenance(name))
            lines.append(f"{f.name} = {_entry(value, f.metadata['unit'], prov)}")
    for f in subs:
        _group(getattr(obj, f.name), f"{prefix}.{f.name}", provenance, override, lines)


def params_text(params: Any, provenance: Provenance, header: str,
                override: Mapping[str, tuple[Any, Mapping[str, Any]]] | None = None) -> str:
    """The complete parameter file of ``params`` (a ``RigParams``): every value with ``provenance(name)``,
    except the dotted names of ``override``, written as ``(value, provenance)``; ``header``: comment lines."""
    lines = [header.rstrip("\n")]
    for f in dataclasses.fields(params):
        if f.name in ("sources", "identified", "high_incidence"):
            continue
        _group(getattr(params, f.name), f.name, provenance, override or {}, lines)
    prov = provenance("high_incidence")
    lines += ["", "[high_incidence]", f"source = {toml_value(prov['source'])}"]
    if prov.get("note"):
        lines.append(f"note = {toml_value(prov['note'])}")
    hi = params.high_incidence
    for f in dataclasses.fields(hi):
        lines.append(f"{f.name} = {toml_value([float(x) for x in getattr(hi, f.name)])}")
    return "\n".join(lines) + "\n"


def write_checked(text: str, path: str | Path, load: Callable[[Path], Any], want: Any, overwrite: bool = False) -> Path:
    """Write ``text`` at ``path`` only if ``load`` reads it back equal to ``want`` (through a temporary file of a
    unique name beside it, then renamed: no other file is touched, and an error names ``path``); FileExistsError
    if ``path`` exists and not ``overwrite``.  Returns the path."""
    path = Path(path)
    if path.is_dir():
        raise ParameterError(f"{path}: is a folder, not a parameter file")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True (rig identify: --overwrite) to replace it")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    tmp = Path(name)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:  # UTF-8 whatever the locale: tomllib reads it so
            fh.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # the mode a new file gets (mkstemp's is 0600)
        try:
            same = load(tmp) == want
        except ParameterError as e:  # the loader names the file it read: name the file being written
            raise ParameterError(str(e).replace(str(tmp), str(path))) from None
        if not same:
            raise ParameterError(f"{path}: the written file does not load back to the same values (a writer bug)")
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path
