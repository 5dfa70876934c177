"""The record checks every reader and the record type share: :class:`RecordError` and the gap rule.

Here, below both :mod:`rig_env.sysid.records` and :mod:`rig_env.sysid.readers`, so that neither imports the other
back (the readers return a record's fields; the record type builds itself from them).
"""

from __future__ import annotations

import numpy as np

GAP_FACTOR = 1.5  # a sample interval over this many median intervals is a gap (check_sampling)


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
