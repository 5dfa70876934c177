"""Append-only binary log of the real-time loop: one fixed-size record per tick, flushed at least every second.

File layout: one line of JSON (the header: ``{"format": "rig-loop-log", "version": 1, "dtype": [...],
...run information}``) terminated by ``\\n``, then records of :data:`RECORD` (numpy structured dtype,
little-endian), appended.  Records go to a preallocated buffer; every ``flush_s`` (default 0.5 s) the
filled part is handed to a writer thread that writes and flushes it (so a slow disk never blocks the
loop: file I/O releases the GIL), and a crash loses at most that much (the operating system's page cache survives a process crash; a power cut may lose more:
``fsync=True`` forces the data to disk at each flush).  :func:`read_log` reads a file back, ignoring a
torn last record.

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
| action | 6 f8 | law output (normalised); command 6 f8: surfaces sent, rad |
| n_foreign, n_corrupt, n_old | u4 | cumulative counts of ignored frames |
"""

from __future__ import annotations

import json
import os
import queue
import threading
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

RECORD = np.dtype([
    ("tick", "<u4"), ("deadline", "<f8"), ("wake", "<f8"), ("send", "<f8"), ("compute", "<f8"),
    ("state", "u1"), ("mode", "u1"), ("fault", "<u2"), ("fresh", "u1"), ("missed", "<u2"),
    ("seq", "<i8"), ("rig_time", "<f8"), ("angles", "<f8", (5,)), ("flaps", "<f8", (4,)), ("airspeed", "<f8"),
    ("obs_t", "<f8"), ("action", "<f8", (6,)), ("command", "<f8", (6,)),
    ("n_foreign", "<u4"), ("n_corrupt", "<u4"), ("n_old", "<u4"),
])


class FrameLog:
    """Preallocated record buffer + append-only file (``path`` None: keep nothing on disk, records still countable)."""

    def __init__(self, path: str | os.PathLike | None, rate_hz: float, header: dict[str, Any], flush_s: float = 0.5, fsync: bool = False) -> None:
        if not 0.0 < flush_s <= 1.0:
            raise ValueError(f"flush_s = {flush_s}: allowed range (0, 1] s")
        self.capacity = int(rate_hz * flush_s) + 2
        self.buf = np.zeros(self.capacity, dtype=RECORD)
        self.n = 0
        self.flush_s, self.fsync = flush_s, fsync
        self.last_flush = 0.0
        self.f: BinaryIO | None = None
        self._q: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self._writer: threading.Thread | None = None
        if path is not None:
            self.f = open(path, "ab")
            h = dict(header, format="rig-loop-log", version=1, dtype=RECORD.descr)
            self.f.write(json.dumps(h).encode() + b"\n")
            self.f.flush()
            self._writer = threading.Thread(target=self._write, name="rig-loop-log", daemon=True)
            self._writer.start()

    def _write(self) -> None:
        while (chunk := self._q.get()) is not None:
            self.f.write(chunk)
            self.f.flush()
            if self.fsync:
                os.fsync(self.f.fileno())

    def next(self) -> np.void:
        """The next record to fill (a view into the buffer); flushes first if the buffer is full."""
        if self.n >= self.capacity:
            self.flush()
        rec = self.buf[self.n]
        self.n += 1
        return rec

    def due(self, now: float) -> bool:
        return now - self.last_flush >= self.flush_s

    def flush(self, now: float | None = None) -> None:
        """Hand the filled records to the writer thread (a copy: the buffer is reused at once)."""
        if self._writer is not None and self.n:
            self._q.put(self.buf[: self.n].tobytes())
        self.n = 0
        if now is not None:
            self.last_flush = now

    def close(self) -> None:
        """Flush, let the writer finish, close the file."""
        self.flush()
        if self._writer is not None:
            self._q.put(None)
            self._writer.join(timeout=10.0)
            self._writer = None
        if self.f is not None:
            self.f.close()
            self.f = None


def read_log(path: str | os.PathLike) -> tuple[dict[str, Any], np.ndarray]:
    """(header, records) of a log file; a torn last record (crash mid-write) is dropped."""
    raw = Path(path).read_bytes()
    nl = raw.index(b"\n")
    header = json.loads(raw[:nl])
    dt = np.dtype([tuple(d) if len(d) == 2 else (d[0], d[1], tuple(d[2])) for d in header["dtype"]])
    body = raw[nl + 1 :]
    n = len(body) // dt.itemsize
    return header, np.frombuffer(body[: n * dt.itemsize], dtype=dt)
