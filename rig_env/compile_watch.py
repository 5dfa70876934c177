"""Say what numba is compiling while it compiles: a first run is never silent for more than a few seconds.

:func:`compile_watch` listens to numba's compile events (``numba.core.event``, ``"numba:compile"``) and,
from a daemon thread, writes a line every ``interval`` seconds while a compile is in flight: the kernel
being compiled, the seconds since the first compile began and the functions compiled so far.  When the
block ends it writes one summary line if anything was compiled.  A compile loaded from numba's disk cache
raises no event, so a warm run prints nothing.  numba's compiler holds the GIL only between its
steps (LLVM runs without it), so the thread gets its turn during a compile.

    with compile_watch(sys.stderr):
        env.step(actions)          # the first step compiles the kernels
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, TextIO


_active = [0]  # watches open in this process: only the outermost reports


@dataclass
class CompileLog:
    """What a :func:`compile_watch` block saw: ``functions`` compiled, ``seconds`` from the first compile's start
    to the last one's end (0 when nothing compiled; it includes whatever ran between compiles), ``compiling``
    the seconds spent inside compiles (the outermost ones' durations summed), ``names`` of the outermost
    kernels compiled."""

    functions: int = 0
    seconds: float = 0.0
    compiling: float = 0.0
    names: list[str] = field(default_factory=list)


def _name(data: Any) -> str:
    disp = data.get("dispatcher") if isinstance(data, dict) else None
    fn = getattr(disp, "py_func", None)
    if fn is None:
        return "a kernel"
    module = str(getattr(fn, "__module__", None) or "").removeprefix("rig_env.")
    return f"{module}.{fn.__qualname__}"


@contextlib.contextmanager
def compile_watch(stream: TextIO | None, *, interval: float = 3.0, label: str = "compiling the numba kernels") -> Iterator[CompileLog]:
    """Report numba compiles on ``stream`` inside the block (module docstring); yields the :class:`CompileLog`.

    ``stream`` None: nothing is listened to or written (the log stays empty); inside another watch, the
    outer one reports and this one's log stays empty.  Lines go to the stream as
    written (``\\r``-updated in place on a terminal).  numba is imported only if it is already loaded:
    a process that runs the kernels as Python (``rig_env.physics.jit.use_python``) compiles nothing."""
    log = CompileLog()
    if stream is None or interval <= 0 or _active[0]:  # an enclosing watch already reports
        yield log
        return
    import sys

    numba = sys.modules.get("numba")
    if numba is None:
        from rig_env.physics import jit

        if jit.mode() != "numba":
            yield log
            return
        numba = jit.setup_numba()
    from numba.core import event

    lock = threading.Lock()
    depth = [0]
    current = [""]
    started = [0.0]
    ended = [0.0]
    entered = [0.0]  # the start of the outermost compile in flight
    tty = bool(getattr(stream, "isatty", lambda: False)())
    said = [False]

    class _Listener(event.Listener):  # type: ignore[misc]
        def on_start(self, ev: Any) -> None:
            with lock:
                if depth[0] == 0:
                    current[0] = _name(ev.data)
                    log.names.append(current[0])
                    entered[0] = time.perf_counter()
                    if not started[0]:
                        started[0] = entered[0]
                depth[0] += 1

        def on_end(self, ev: Any) -> None:
            with lock:
                depth[0] = max(0, depth[0] - 1)
                log.functions += 1
                ended[0] = time.perf_counter()
                if depth[0] == 0:
                    log.compiling += ended[0] - entered[0]

    def write(text: str) -> None:
        try:
            stream.write(("\r" + text.ljust(100)) if tty else text + "\n")
            stream.flush()
        except (OSError, ValueError):
            pass

    stop = threading.Event()

    def tick() -> None:
        last = time.perf_counter()
        while not stop.wait(0.25):
            with lock:
                busy = depth[0] > 0
                t0, name, n = started[0], current[0], log.functions
            now = time.perf_counter()
            if busy and now - last >= interval:
                last = now
                said[0] = True
                write(f"  {label} (once; later runs load them from the disk cache): {now - t0:4.0f} s, {n} functions, now {name}")

    listener = _Listener()
    event.register("numba:compile", listener)
    _active[0] += 1
    thread = threading.Thread(target=tick, name="rig_env-compile-watch", daemon=True)
    thread.start()
    try:
        yield log
    finally:
        stop.set()
        thread.join(timeout=1.0)
        event.unregister("numba:compile", listener)
        _active[0] -= 1
        if log.functions:
            log.seconds = ended[0] - started[0]
            if said[0] or log.compiling >= interval:
                # the seconds spent compiling, not the span from the first compile to the last (the work between them,
                # e.g. a comparison's batches, is not compiling; that span once read as 16 s of compiling, which were 0.3 s)
                write(f"  compiled {log.functions} numba functions in {log.compiling:.0f} s (cached on disk for later runs)")
                if tty:
                    stream.write("\n")


__all__ = ["CompileLog", "compile_watch"]
