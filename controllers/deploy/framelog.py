"""Binary log of the real-time loop, written once to a new file: one fixed-size record per tick, flushed every ``flush_s``.

The format (the header line, the :data:`RECORD` dtype and its field table, :func:`read_log`) is
:mod:`rig_env.framelog_format`, shared with the identification's reader (``rig_env.sysid.FlightRecord.read``);
this module re-exports ``RECORD`` and ``read_log``.  Records go to a preallocated buffer; every ``flush_s``
(default 0.5 s) the filled part is handed to a writer thread that writes and flushes it (so a slow disk
never blocks the loop: file I/O releases the GIL), and a crash loses at most that much (the operating
system's page cache survives a process crash; a power cut may lose more: ``fsync=True`` forces the data
to disk at each flush).

Log policy: the file is created exclusively (``open(path, "xb")``): an existing path -- an earlier log, an
artefact, a device such as ``/dev/full`` -- is refused with :class:`LogPathError` before anything is
written, so a log is never appended to and never overwrites another file.  A write that fails (disk
full, quota, I/O error) is never raised in the loop's thread: the writer thread records it in
:attr:`FrameLog.error` (a message naming the path) and drops the records from then on; the loop polls
``error`` every tick and treats it as a fault (:mod:`controllers.deploy.loop`).  :meth:`FrameLog.close`
never raises either.
"""

from __future__ import annotations

import os
import queue
import threading
from typing import Any, BinaryIO

import numpy as np

from rig_env.framelog_format import RECORD, header_line, read_log

__all__ = ["RECORD", "FrameLog", "LogPathError", "LogWriteError", "read_log"]


class LogPathError(ValueError):
    """The log path is refused before the run (it exists, or its folder does not); the message names the path."""


class LogWriteError(OSError):
    """The log's header could not be written (``rig-deploy run`` exits 5); errno, message and the path as an OSError."""


class FrameLog:
    """Preallocated record buffer + a new file (``path`` None: keep nothing on disk, records still countable).

    path: a path that must not exist yet (:class:`LogPathError` otherwise; an OSError from creating or
    writing the header names the path).  rate_hz: the loop's rate, Hz (sizes the buffer: ``rate_hz *
    flush_s + 2`` records).  header: the run's information for the header line.  flush_s: seconds
    between hand-overs to the writer thread, (0, 1].  fsync: force the data to disk at each flush.
    """

    def __init__(self, path: str | os.PathLike | None, rate_hz: float, header: dict[str, Any], flush_s: float = 0.5, fsync: bool = False) -> None:
        if not 0.0 < flush_s <= 1.0:
            raise ValueError(f"flush_s = {flush_s}: allowed range (0, 1] s")
        self.capacity = int(rate_hz * flush_s) + 2
        self.buf = np.zeros(self.capacity, dtype=RECORD)
        self.n = 0
        self.flush_s, self.fsync = flush_s, fsync
        self.last_flush = 0.0
        self.path = None if path is None else os.fspath(path)
        self.error: str | None = None
        """None while every write succeeded; else what failed, naming the path (set by the writer thread)."""
        self.f: BinaryIO | None = None
        self._q: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self._writer: threading.Thread | None = None
        if path is not None:
            try:
                self.f = open(path, "xb")
            except FileExistsError:
                raise LogPathError(f"--log {self.path}: already exists; a log is never appended to nor overwrites a file: give a new path") from None
            except FileNotFoundError:
                raise LogPathError(f"--log {self.path}: its folder does not exist") from None
            try:
                self.f.write(header_line(header))
                self.f.flush()
            except OSError as e:
                self.f.close()
                self.f = None
                raise LogWriteError(e.errno, f"cannot write the log header ({e.strerror})", self.path) from None
            self._writer = threading.Thread(target=self._write, name="rig-loop-log", daemon=True)
            self._writer.start()

    def _write(self) -> None:
        """Writer thread: write and flush each chunk; on the first failure record it and drop the rest."""
        while (chunk := self._q.get()) is not None:
            if self.error is not None:
                continue
            try:
                self.f.write(chunk)
                self.f.flush()
                if self.fsync:
                    os.fsync(self.f.fileno())
            except (OSError, ValueError) as e:  # ValueError: a closed file
                self.error = f"{self.path}: log write failed ({getattr(e, 'strerror', None) or e})"

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
        """Flush, let the writer finish, close the file; never raises (a failure ends up in :attr:`error`)."""
        self.flush()
        if self._writer is not None:
            self._q.put(None)
            self._writer.join(timeout=10.0)
            if self._writer.is_alive() and self.error is None:
                self.error = f"{self.path}: the log writer did not finish within 10 s"
            self._writer = None
        if self.f is not None:
            try:
                self.f.close()
            except OSError as e:
                if self.error is None:
                    self.error = f"{self.path}: closing the log failed ({e.strerror or e})"
            self.f = None
