"""The record checks every reader, the record type and the fit share: :class:`RecordError`, the gap rule, the
samples a fitted record needs, the rule for record names that go into file and parameter names, and what a
number is (Python's or numpy's, not a bool).

Here, below both :mod:`rig_env.sysid.records` and :mod:`rig_env.sysid.readers`, so that neither imports the other
back (the readers return a record's fields; the record type builds itself from them).
"""

from __future__ import annotations

import math
import numbers
import re
from typing import Any, Callable, Sequence

import numpy as np

GAP_FACTOR = 1.5  # a sample interval over this many median intervals is a gap (check_sampling)

MIN_RECORD_SAMPLES = 10
"""Samples a record must hold to be fitted (``sysid.fit``, ``rig identify``): the residuals' whiteness test then
has two lags (n // 5, :func:`rig_env.sysid.diagnostics.default_max_lag`); a 2-sample record failed only inside the
fit, and a 5-sample one gave estimates without meaning."""


class RecordError(ValueError):
    """A record that cannot be used: the message names the field and what is allowed."""


def check_sampling(t: np.ndarray, name: str = "record", allow_gaps: bool = False, factor: float = GAP_FACTOR) -> None:
    """Raise :class:`RecordError` at the first gap in the sample times ``t`` (n,), s (the readers' check).

    A gap is an interval longer than ``factor`` (1.5) times the median interval: one lost sample on a
    regular grid doubles an interval, while a real-time loop's timing jitter stays well inside half a
    period.  ``allow_gaps``: skip the check (a record with lost frames, interpolated over afterwards).
    """
    if allow_gaps or np.size(t) < 3:
        return
    dt = np.diff(np.asarray(t, dtype=np.float64))
    med = float(np.median(dt))
    long = dt > factor * med
    if long.any():
        k = int(np.argmax(long))
        raise RecordError(f"{name}: t: gap of {dt[k]:.6g} s after t = {t[k]:.6g} s ({int(long.sum())} interval(s) longer than {factor:g} x the "
                          f"median {med:.6g} s); select the parts around it with segment(), or read with allow_gaps=True")


def is_number(v: Any) -> bool:
    """A real number, Python's or numpy's (``numbers.Real``, which numpy's bool is not), not a bool."""
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def is_integer(v: Any) -> bool:
    """An integer, Python's or numpy's (not a bool)."""
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


def number(label: str, v: Any, error: type[Exception] = ValueError, allowed: str = "a finite number") -> float:
    """``v`` as a float if it is a finite real number (Python's or numpy's, not a bool), else ``error`` naming
    ``label`` and ``allowed``."""
    if not (is_number(v) and math.isfinite(v)):
        raise error(f"{label} = {v!r}: must be {allowed}")
    return float(v)


def record_slug(name: str) -> str:
    """The part of a record's name that goes into file names (the report's figures): runs of characters other
    than letters, digits, ``_``, ``.`` and ``-`` become ``_``."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "record"


def check_record_names(names: Sequence[str], figures: Callable[[str], Sequence[str]] | None = None) -> None:
    """RecordError naming the first two records (by position and name) whose names are the same or share a
    :func:`record_slug`: their report figures would be one file (``figures(name)``: the file names of a record's
    figures, for the message) and, with the same name, their estimated initial states and biases
    (``x0.<record>.<joint>``, ``bias.<record>.<output>``) one parameter.  The message says how to rename."""
    seen: dict[str, int] = {}
    for i, n in enumerate(names):
        s = record_slug(n)
        if s in seen:
            j = seen[s]
            files = ", ".join(figures(n)) if figures is not None else f"history_{s}.png, acf_{s}.png"
            fitted = f"estimated initial states (x0.{n}.<joint>), biases and " if figures is None else ""
            what = (f"the same name, so their {fitted}report figures ({files})" if names[j] == n
                    else f"names of one file-name form {s!r}, so their report figures ({files})")
            raise RecordError(f"records[{j}] {names[j]!r} and records[{i}] {n!r}: {what} would collide; give each record its own "
                              "name (FlightRecord(name=...), FlightRecord.read(..., name=...) or dataclasses.replace(record, name=...); "
                              "rig identify: the [[record]] table's name = ...)")
        seen[s] = i
