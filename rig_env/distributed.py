"""Scale-out on Ray: the pieces every distributed run shares (the comparison, the training sweep, the
identification Monte-Carlo).

Ray's engine does the distribution (core tasks and their retries, Ray Tune); this module only

* imports Ray, or says which extra installs it (:func:`require_ray`, a :class:`BackendError`, a ValueError
  the command line reports in one line, exit 2);
* connects to a cluster or starts a local one (:func:`connect`; ``address=None``: a local cluster on this
  machine, ``"auto"``: the running cluster, ``"HOST:PORT"``: a remote head) and leaves an already
  connected session alone;
* points every worker at a node-local numba cache and compiles the kernels once per node
  (:func:`node_setup`, :func:`warm_once`): the first task on a node compiles under a file lock in that
  node's cache directory, later tasks on the node (any worker process) load the cache;
* keeps the books of a distributed run in a small actor on the driver's node (:class:`Ledger`): which
  work unit started how many times (a retry after a lost worker or node is a second start), which
  finished, and prints the progress every few seconds (:func:`wait_all`).

Ray is imported inside functions only: importing this module costs nothing without Ray.
"""

from __future__ import annotations

import os
import socket
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator, Sequence, TextIO

BACKENDS = ("local", "ray")
EXTRA = 'pip install -e ".[ray]"'
PROGRESS_EVERY_S = 5.0
"""Seconds between progress lines of a distributed run."""
MAX_RETRIES = 4
"""Ray task retries after a lost worker process or node (system failures only: an exception in our own
code is an error, not retried)."""


class BackendError(ValueError):
    """A backend that cannot be used (unknown name, Ray missing, bad address or chunk size); the message names the option."""


def require_ray() -> Any:
    """The ``ray`` module, or a :class:`BackendError` naming the extra that installs it."""
    try:
        import ray
    except ImportError:
        raise BackendError(f"--backend ray: Ray is not installed; install the optional extra: {EXTRA}") from None
    return ray


def check_backend(backend: str, address: str | None = None) -> None:
    """A :class:`BackendError` for an unknown ``backend``, an ``address`` without ``backend="ray"``, or Ray missing."""
    if backend not in BACKENDS:
        raise BackendError(f"--backend {backend!r}: allowed {list(BACKENDS)}")
    if address is not None and backend != "ray":
        raise BackendError(f"--address {address!r}: only with --backend ray")
    if address is not None and (not isinstance(address, str) or not address.strip()):
        raise BackendError(f"--address {address!r}: give auto, HOST:PORT or ray://HOST:PORT")
    if address is not None:
        host_port(address)
    if backend == "ray":
        require_ray()


CONNECT_TIMEOUT_S = 5.0
"""Seconds :func:`connect` waits for a TCP answer at ``HOST:PORT`` before Ray is asked (Ray itself retries for minutes)."""


def host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of a ``HOST:PORT`` or ``ray://HOST:PORT`` address, None for ``"auto"``; a :class:`BackendError`
    naming ``--address`` for any other form or a port outside [1, 65535]."""
    if address == "auto":
        return None
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise BackendError(f"--address {address!r}: give auto, HOST:PORT or ray://HOST:PORT, the port an integer in [1, 65535]")
    return host.strip("[]"), int(port)


def check_chunk_size(chunk_size: int | None, limit: int = 100_000) -> None:
    """A :class:`BackendError` unless ``chunk_size`` is None or an integer in [1, limit]."""
    if chunk_size is None:
        return
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or not 1 <= chunk_size <= limit:
        raise BackendError(f"--chunk-size = {chunk_size!r}: must be an integer in [1, {limit}] (work units per Ray task)")


def worker_env() -> dict[str, str]:
    """Environment variables every worker inherits from the driver: the numba cache directory when the driver
    names one (each node then uses that path on its own disk) and the one-thread pools of a shared machine."""
    keep = ("NUMBA_CACHE_DIR", "RIG_ENV_FAST_INLINE", "NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
            "MKL_NUM_THREADS", "PYTHONPATH")
    env = {k: os.environ[k] for k in keep if os.environ.get(k)}
    for k in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env.setdefault(k, "1")  # one CPU per task: Ray schedules by CPUs, numba and BLAS must not take more
    return env


def connect(address: str | None = None, *, num_cpus: int | None = None) -> bool:
    """Connect to Ray: ``address`` None starts a local cluster on this machine (``num_cpus``: its CPUs, default
    all), ``"auto"`` or ``"HOST:PORT"`` joins a running one.  Returns True when this call started the session
    (the caller shuts it down, :func:`session`); False when a session was already up (left as it is).
    A cluster that cannot be reached is a :class:`BackendError` naming ``--address``: at ``HOST:PORT`` a TCP probe
    first, which fails within :data:`CONNECT_TIMEOUT_S` (even when a session is already up)."""
    ray = require_ray()
    hp = host_port(address) if address is not None else None
    if hp is not None:  # Ray retries an address where nothing listens for minutes, silently: ask first
        try:
            socket.create_connection(hp, timeout=CONNECT_TIMEOUT_S).close()
        except OSError as exc:
            raise BackendError(f"--address {address!r}: nothing answers at {hp[0]}:{hp[1]} within {CONNECT_TIMEOUT_S:g} s ({exc}); "
                               "is a Ray head running there (ray start --head --port PORT)?") from None
    if ray.is_initialized():
        return False
    kw: dict[str, Any] = {"runtime_env": {"env_vars": worker_env()}, "logging_level": "ERROR", "log_to_driver": False}
    if address is None:
        kw.update(include_dashboard=False, num_cpus=num_cpus)
    try:
        ray.init(address=address, **kw)
    except (ConnectionError, RuntimeError, ValueError) as exc:
        raise BackendError(f"--address {address!r}: cannot connect to a Ray cluster ({exc})") from None
    return True


@contextmanager
def session(address: str | None = None, *, num_cpus: int | None = None) -> Iterator[Any]:
    """``with session(address) as ray:``: :func:`connect`, and shut down on exit what this call started."""
    owned = connect(address, num_cpus=num_cpus)
    ray = require_ray()
    try:
        yield ray
    finally:
        if owned:
            ray.shutdown()


def cluster_cpus() -> int:
    """CPUs of the connected cluster (at least 1)."""
    ray = require_ray()
    return max(1, int(ray.cluster_resources().get("CPU", 1)))


# ----------------------------------------------------------------- on the workers
def node_cache_dir() -> str:
    """This node's numba cache directory: ``NUMBA_CACHE_DIR`` when set (the driver's path, on this node's own
    disk), else the project's default under the user's cache (:func:`rig_env.physics.jit.cache_dir`)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.environ["NUMBA_CACHE_DIR"]
    import numba

    from rig_env.physics.jit import cache_dir

    return cache_dir(numba.__version__)


def node_setup() -> dict[str, Any]:
    """Run first in every task, before any kernel is imported: fix the numba cache directory of this node (so
    every worker process on the node shares one compiled cache) and the one-thread pools; returns where this
    task runs (``node``: Ray's node id, ``host``, ``pid``, ``cache_dir``)."""
    path = node_cache_dir()
    os.environ["NUMBA_CACHE_DIR"] = path  # before numba is imported in this process (numba reads it at import)
    for k in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(k, "1")
    Path(path).mkdir(parents=True, exist_ok=True)
    node = ""
    try:
        import ray

        if ray.is_initialized():
            node = ray.get_runtime_context().get_node_id()
    except ImportError:
        pass
    return {"node": node, "host": socket.gethostname(), "pid": os.getpid(), "cache_dir": path}


_warmed: set[str] = set()


def warm_once(key: str, warm: Any) -> float:
    """Call ``warm()`` (something that compiles or loads the kernels a task needs) once per process and ``key``,
    under an exclusive lock file in the node's cache directory: the first process on a node compiles and
    writes the cache while the others wait, then they load it.  Returns the seconds spent (0 when done before)."""
    if key in _warmed:
        return 0.0
    import fcntl

    path = Path(node_cache_dir()) / ".rig_env_warm.lock"
    path.parent.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with open(path, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            warm()
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)
    _warmed.add(key)
    return time.perf_counter() - t0


# ----------------------------------------------------------------- the books
class Ledger:
    """The books of a distributed run (a Ray actor on the driver's node, :func:`make_ledger`): every work unit's
    starts (a start after the first is a retry), who ran it (node, pid) and whether it finished."""

    def __init__(self, total: int, unit: str) -> None:
        self.total, self.unit = total, unit
        self.starts: dict[str, list[dict[str, Any]]] = {}
        self.finished: dict[str, int] = {}  # key -> size (episodes, fits, ...)

    def start(self, key: str, where: dict[str, Any]) -> int:
        """Record a start of ``key``; returns its attempt number (1 for the first)."""
        self.starts.setdefault(key, []).append(dict(where))
        return len(self.starts[key])

    def finish(self, key: str, size: int) -> None:
        self.finished[key] = size

    def snapshot(self) -> dict[str, Any]:
        """done (units of work finished, e.g. episodes), running (keys started and not finished), retried (keys
        started more than once), retries (starts beyond the first), attempts (key -> list of starts)."""
        running = [k for k in self.starts if k not in self.finished]
        retried = sorted(k for k, v in self.starts.items() if len(v) > 1)
        return {"total": self.total, "unit": self.unit, "done": sum(self.finished.values()), "finished": len(self.finished),
                "running": len(running), "retried": retried, "retries": sum(len(v) - 1 for v in self.starts.values()),
                "attempts": {k: list(v) for k, v in self.starts.items()}}


LEDGER_PREFIX = "rig-ledger"


def make_ledger(total: int, unit: str, name: str | None = None) -> Any:
    """A :class:`Ledger` actor pinned to the driver's node (it survives the loss of any worker node); ``name``:
    registered as ``rig-ledger-<name>`` (so that a test or a monitor can find it)."""
    ray = require_ray()
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    here = ray.get_runtime_context().get_node_id()
    cls = ray.remote(num_cpus=0, max_restarts=0)(Ledger)
    opts: dict[str, Any] = {"scheduling_strategy": NodeAffinitySchedulingStrategy(here, soft=False)}
    if name is not None:
        opts["name"] = f"{LEDGER_PREFIX}-{name}"
    return cls.options(**opts).remote(total, unit)


def progress_line(label: str, snap: dict[str, Any], elapsed: float) -> str:
    """One progress line: ``label: done/total unit done, running, retried``."""
    return (f"  ray {label}: {snap['done']}/{snap['total']} {snap['unit']} done, {snap['running']} task(s) running, "
            f"{snap['retries']} retried, {elapsed:.0f} s")


def wait_all(refs: Sequence[Any], ledger: Any, label: str, stream: TextIO | None = None,
             every: float = PROGRESS_EVERY_S, timeout: float | None = None) -> list[Any]:
    """``ray.get`` of every ref in order, printing :func:`progress_line` to ``stream`` every ``every`` seconds
    while they run (None: silent).  ``timeout`` s: a TimeoutError when the run takes longer."""
    ray = require_ray()
    pending = list(refs)
    t0 = last = time.perf_counter()
    while pending:
        _, pending = ray.wait(pending, num_returns=len(pending), timeout=min(every, 1.0))
        now = time.perf_counter()
        if stream is not None and pending and now - last >= every:
            stream.write(progress_line(label, ray.get(ledger.snapshot.remote()), now - t0) + "\n")
            stream.flush()
            last = now
        if timeout is not None and now - t0 > timeout:
            raise TimeoutError(f"{label}: not finished after {timeout:.0f} s")
    return list(ray.get(list(refs)))


def default_stream() -> TextIO:
    return sys.stderr
