"""Identified parameters back into a parameter file that every part of the model loads.

:func:`write_params` writes a complete parameter file (every group and value, laid out as
``rig_env/data/default_rig.toml``): each identified value with ``source = "identified"``, its
Cramer-Rao standard error ``std`` (the value's unit), the ``records`` it was fitted to, the ``method``
and a note; every other value with the source and note it had.  ``RigParams.from_toml`` loads it back
to the same values, so it flies in ``simulate()``, the environments (``RigEnvConfig.params_file``), the
laws' design (``params=``) and ``rig compare --params``.  :func:`save_fit_params` does it for a
:class:`~rig_env.sysid.result.Fit`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

from rig_env.params import DEFAULT_FILE, IDENTIFIED_KEYS, PARAM_INDEX, ParameterError, RigParams
from rig_env.params_io import IDENTIFICATION_METHODS, params_text, write_checked
from rig_env.sysid.result import Fit

HEADER = """# Rig parameters with identified values (written by rig_env.sysid.paramfile).
# Every value: source = paper | rig-code | estimate | identified; identified values carry std (Cramer-Rao
# standard error, the value's unit), the records they were fitted to and the method.
# Units SI unless the field name says _deg, _deg_s or _hz. Axes: x towards the model (upstream), y starboard, z down.
"""


def _check_identified(identified: Mapping[str, Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    out = {}
    for name, entry in identified.items():
        if name not in PARAM_INDEX:
            raise ParameterError(f"identified: unknown parameter {name!r}; valid names: rig_env.PARAM_NAMES")
        keys = {"value", *IDENTIFIED_KEYS}
        if set(entry) != keys:
            raise ParameterError(f"identified[{name!r}]: needs exactly the keys {sorted(keys)}, got {sorted(entry)}")
        recs = [entry["records"]] if isinstance(entry["records"], str) else list(entry["records"])
        std = float(entry["std"])
        if not (math.isfinite(std) and std >= 0):
            raise ParameterError(f"identified[{name!r}].std = {std!r}: must be finite and >= 0")
        if entry["method"] not in IDENTIFICATION_METHODS:
            raise ParameterError(f"identified[{name!r}].method = {entry['method']!r}; allowed: {', '.join(IDENTIFICATION_METHODS)}")
        out[name] = {"value": float(entry["value"]), "std": std, "records": recs, "method": str(entry["method"])}
    return out


def params_toml(params: RigParams, identified: Mapping[str, Mapping[str, Any]] | None = None,
                base_file: str | Path | None = None) -> str:
    """The text of :func:`write_params` (same arguments, nothing written)."""
    ident = _check_identified(identified or {})
    base = RigParams.from_toml(DEFAULT_FILE if base_file is None else base_file)
    params = params.replace(**{k: e["value"] for k, e in ident.items()}) if ident else params
    override = {k: (e["value"], {"source": "identified", "note": f"identified by {e['method']} from {', '.join(e['records'])}", **e})
                for k, e in ident.items()}
    return params_text(params, lambda name: params.file_provenance(name, base), HEADER, override)


def write_params(params: RigParams, path: str | Path, *, identified: Mapping[str, Mapping[str, Any]] | None = None,
                 base_file: str | Path | None = None, overwrite: bool = False) -> Path:
    """Write ``params`` as a complete parameter file at ``path`` and return the path.

    identified: ``{dotted name: {"value": v, "std": s, "records": [names], "method": m}}`` (value and
    std in the parameter file's units); these values replace those of ``params`` and are tagged
    ``source = "identified"``.  Every other value keeps its source and note from ``params.sources``,
    or, where ``params`` has none (a value set by ``RigParams.replace``), from ``base_file`` (default:
    the default rig) if it holds the same value; otherwise a ParameterError names the value.  The file
    is loaded back before it is written (``RigParams.from_toml`` validates it and must give the same
    values).  FileExistsError if ``path`` exists and not ``overwrite``.  The format is
    :mod:`rig_env.params_io`'s (also :meth:`RigParams.to_toml`'s).
    """
    path = Path(path)
    if path.is_dir():
        raise ParameterError(f"{path}: is a folder, not a parameter file")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True (rig identify: --overwrite) to replace it")
    text = params_toml(params, identified, base_file)
    want = params.replace(**{k: float(e["value"]) for k, e in (identified or {}).items()}) if identified else params
    return write_checked(text, path, RigParams.from_toml, want, overwrite)


def fit_identified(fit: Fit) -> dict[str, dict[str, Any]]:
    """The ``identified`` mapping of :func:`write_params` for a fit: its estimates, corrected standard
    errors, record names and method."""
    recs = [r.name for r in fit.records]
    return {k: {"value": float(fit.values[k]), "std": float(fit.std[k]), "records": recs, "method": fit.method} for k in fit.estimate}


def save_fit_params(fit: Fit, path: str | Path, *, base_file: str | Path | None = None, overwrite: bool = False) -> Path:
    """Write ``fit.params`` with the fit's estimates tagged ``identified`` (:func:`write_params`)."""
    return write_params(fit.params, path, identified=fit_identified(fit), base_file=base_file, overwrite=overwrite)
