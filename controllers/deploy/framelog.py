"""Append-only binary log of the real-time loop: one fixed-size record per tick, flushed at least every second.

The format (the header line, the :data:`RECORD` dtype and its field table, :func:`read_log`) is
:mod:`rig_env.framelog_format`, shared with the identification's reader (``rig_env.sysid.FlightRecord.read``);
this module re-exports ``RECORD`` and ``read_log``.  Records go to a preallocated buffer; every ``flush_s``
(default 0.5 s) the filled part is handed to a writer thread that writes and flushes it (so a slow disk
never blocks the loop: file I/O releases the GIL), and a crash loses at most that much (the operating
system's page cache survives a process crash; a power cut may lose more: ``fsync=True`` forces the data
to disk at each flush).
"""

from __future__ import annotations

import os
import queue
import threading
from typing import Any, BinaryIO

import numpy as np

from rig_env.framelog_format import RECORD, header_line, read_log

__all__ = ["RECORD", "FrameLog", "read_log"]


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
            self.f.write(header_line(header))
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

