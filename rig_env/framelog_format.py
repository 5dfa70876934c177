"""The real-time loop's frame-log format: one JSON header line, then fixed-size binary records.

Defined here, in the lowest layer of ``rig_env`` (numpy, json and the standard library only), so that the
loop that writes logs (:class:`controllers.deploy.framelog.FrameLog`) and the identification that reads
them (:mod:`rig_env.sysid.readers`) share one copy without ``rig_env`` importing a controller.

File layout: one line of JSON terminated by ``\\n`` (the header: ``{"format": "rig-loop-log", "version": 1,
"dtype": [...], ...run information}``), then records of :data:`RECORD` (numpy structured dtype,
little-endian).  The writer creates the file exclusively (never appends), so one file holds one header.
:func:`read_log` refuses a file with a cut header (no newline, or a line that is not a JSON header) or a
second header (a log appended to an older file: the records after it would be misaligned), and drops a
torn last record (a crash mid-write) with a :class:`TornLogWarning`, reporting it in the returned
header as ``torn_bytes`` (the bytes dropped; 0 when the file ends on a record boundary).

Header keys written by the loop: ``format``, ``version``, ``dtype`` (this module), and the run's
``artefact_sha256``, ``kind``, ``task``, ``rate_hz`` (Hz), ``free_dofs`` (the law's free joints, JOINTS
names; logs written before it was added lack it), ``rig``, ``seed``, ``stale_frames``, ``fault_frames``,
``stuck_frames``, ``stuck_cmd_deg``.

| field | type | unit / meaning |
|---|---|---|
| tick | u4 | loop tick k (deadline ``start + k period``) |
| deadline, wake, send | f8 | s since the loop's start: the tick's deadline, wake-up, command sent |
| compute | f8 | s spent in the law's ``act`` (0 when not called) |
| state | u1 | 0 DISARMED, 1 ACTIVE, 2 FAULT (:mod:`controllers.deploy.loop`) |
| mode | u1 | command mode sent (protocol: 0 DISARMED, 1 ACTIVE, 2 SAFE) |
| fault | u2 | latched fault bits (``loop.FAULTS``) |
| fresh | u1 | 1 if a new sensor frame was used this tick |
| missed | u2 | consecutive ticks without a new frame |
| seq | i8 | sensor frame seq used (-1: none yet) |
| rig_time | f8 | its rig time, s |
| angles | 5 f8 | rad (JOINTS order); flaps 4 f8 rad; airspeed f8 m/s |
| obs_t | f8 | time given to the task reference, s |
| action | 6 f8 | law output (normalised); command 6 f8: surfaces sent after this tick's frame, rad (SURFACES order) |
| n_foreign, n_corrupt, n_old | u4 | cumulative counts of ignored frames |
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np

FORMAT = "rig-loop-log"
VERSION = 1

RECORD = np.dtype([
    ("tick", "<u4"), ("deadline", "<f8"), ("wake", "<f8"), ("send", "<f8"), ("compute", "<f8"),
    ("state", "u1"), ("mode", "u1"), ("fault", "<u2"), ("fresh", "u1"), ("missed", "<u2"),
    ("seq", "<i8"), ("rig_time", "<f8"), ("angles", "<f8", (5,)), ("flaps", "<f8", (4,)), ("airspeed", "<f8"),
    ("obs_t", "<f8"), ("action", "<f8", (6,)), ("command", "<f8", (6,)),
    ("n_foreign", "<u4"), ("n_corrupt", "<u4"), ("n_old", "<u4"),
])


class TornLogWarning(UserWarning):
    """The log's last record is incomplete (a crash mid-write); :func:`read_log` dropped it."""


_HEADER_MARK = json.dumps({"format": FORMAT})[1:-1].encode()  # '"format": "rig-loop-log"', as json.dumps writes it


def header_line(run: dict[str, Any]) -> bytes:
    """The header line (JSON + ``\\n``) for a run's information ``run`` (any JSON-serialisable dict)."""
    h = dict(run, format=FORMAT, version=VERSION, dtype=RECORD.descr)
    return json.dumps(h).encode() + b"\n"


def is_log(path: str | os.PathLike) -> bool:
    """True if the file starts with a frame-log header line (reads at most the first 64 kB)."""
    try:
        with open(path, "rb") as f:
            head = f.read(65536)
    except OSError:
        return False
    if not head.startswith(b"{") or b"\n" not in head:
        return False
    try:
        return json.loads(head[: head.index(b"\n")]).get("format") == FORMAT
    except (ValueError, AttributeError):
        return False


def read_log(path: str | os.PathLike) -> tuple[dict[str, Any], np.ndarray]:
    """(header, records) of a log file.

    A torn last record (crash mid-write) is dropped with a :class:`TornLogWarning`; the returned header
    then carries ``torn_bytes`` (the bytes dropped; 0 otherwise).  Raises ValueError naming the path for
    a file that is not a frame log (no header line, or another ``format``), a cut or damaged header, and
    a second header anywhere in the records (a log appended to another).
    """
    raw = Path(path).read_bytes()
    nl = raw.find(b"\n")
    if raw.startswith(b"{") and _HEADER_MARK in raw[: nl if nl >= 0 else len(raw)]:
        try:
            header = json.loads(raw[:nl]) if nl >= 0 else None
        except ValueError:
            header = None
        if not isinstance(header, dict):
            raise ValueError(f"{path}: the frame log's header is cut or damaged ({'no newline after it' if nl < 0 else 'not valid JSON'}); "
                             f"{len(raw)} bytes")
    else:
        try:
            header = json.loads(raw[:nl]) if nl >= 0 else None
        except ValueError:
            header = None
    if not isinstance(header, dict) or header.get("format") != FORMAT or "dtype" not in header:
        raise ValueError(f"{path}: not a frame log (the first line must be a JSON header with format {FORMAT!r} and dtype)")
    second = raw.find(_HEADER_MARK, nl + 1)  # 24 bytes of text: by chance in binary records with probability ~1e-58 per offset
    if second >= 0:
        raise ValueError(f"{path}: a second log header near byte {second} (a log appended to an earlier one?): the records after it "
                         f"would be misaligned; split the file at that byte")
    try:
        dt = np.dtype([tuple(d) if len(d) == 2 else (d[0], d[1], tuple(d[2])) for d in header["dtype"]])
    except (TypeError, ValueError, IndexError) as e:
        raise ValueError(f"{path}: the header's dtype is not a record layout: {e}") from None
    if dt.itemsize == 0:
        raise ValueError(f"{path}: the header's dtype has no fields")
    body = raw[nl + 1 :]
    n, torn = divmod(len(body), dt.itemsize)
    header["torn_bytes"] = torn
    if torn:
        warnings.warn(f"{path}: the last record is torn ({torn} of {dt.itemsize} bytes; a crash mid-write?): dropped", TornLogWarning, stacklevel=2)
    return header, np.frombuffer(body[: n * dt.itemsize], dtype=dt)
