"""Kernels compiled by numba on their first call, or run as plain Python in a process without numba.

``@kernel(**numba_options)`` (the options of ``numba.njit``) turns a function into a :class:`Kernel`:
importing the module that defines it imports nothing of numba.  Its first call decides how it runs:

| mode | when | a call runs |
|---|---|---|
| ``"numba"`` | default when numba is installed | ``numba.njit(**options)(fn)``, created (and compiled or loaded from the disk cache) at the first call |
| ``"python"`` | :func:`use_python`, ``RIG_ENV_JIT=python``, or numba not installed | ``fn`` itself (or the kernel's ``python=`` twin) on numpy scalars, floating-point errors silenced as numba's ``error_model="numpy"`` does |

The rig's real-time loop (``rig-deploy run``, :mod:`controllers.deploy.cli`) builds and runs its loop
inside :func:`python_mode` (:func:`use_python` until it returns), so that process never imports numba,
llvmlite or anything compiled; the kernels it calls (the sensors' and the task's, for one environment
at 80 Hz) take tens of microseconds in Python and give the same float32 observations bit for bit
(``tests/test_jit.py``).  The environments
run in ``"numba"`` mode.  :func:`use_numba` switches back (both apply to every kernel, at its next call).

Kernels inside kernels: numba compiles a kernel that calls another (a global ``_clip`` or an attribute
``vmath.sincos``) because a :class:`Kernel` answers numba's two questions as its dispatcher would:
``_numba_type_`` (the type of the global: the dispatcher's) and ``targetoptions`` / ``py_func`` (read by
numba's IR inliner, so ``inline="always"`` kernels are still inlined at IR level into their callers,
physics or lazy).  :func:`intrinsic` is the same for ``numba.extending.intrinsic`` (a Python twin is
required: an intrinsic has no Python body).  ``prange`` is ``range`` in Python; in numba mode a kernel
that uses it is compiled from a copy of the function whose global ``prange`` is ``numba.prange``.

numba set-up, before any kernel is decorated or compiled (:func:`setup_numba`, run as soon as numba is
imported in a process that imported :mod:`rig_env`, see :mod:`rig_env.importhook`):

* numba's on-disk cache (``cache=True``) checks only the source file of the function it compiled, not
  the files of the functions it inlined: after an edit to ``aero.py`` a cached ``integrator.step_batch``
  would still run the old aerodynamics.  Unless the user sets ``NUMBA_CACHE_DIR`` themselves, the
  kernels therefore cache under a directory named by a hash of every source file of
  :mod:`rig_env.physics` (and numba's version), so any change to the physics invalidates every cached
  kernel at once.
* one cache for every installation of the same sources: numba files a function's cache under a hash of
  the *absolute* directory of its source, so the README's two quick-start installs (``pip install .``
  into site-packages, then ``pip install -e .`` from the checkout) would each compile everything once.
  :class:`PackageCacheLocator` files rig_env's kernels under their directory *inside the package*
  (``rig_env/physics``...) instead; numba's source stamp is already a hash of the file's content, so a
  second installation of the same sources finds the first one's kernels.  Functions outside rig_env keep
  numba's own locators.
* the compile-time fix for numba's IR inliner (:mod:`rig_env.physics.fast_inline`;
  ``RIG_ENV_FAST_INLINE=0`` turns it off).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import os
import struct
import threading
import types as _pytypes
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

MODES = ("numba", "python")
prange = range
"""``range`` when a kernel runs as Python; ``numba.prange`` when numba compiles it."""

_mode: str | None = None
_numba: Any = None
_setup_lock = threading.RLock()
_kernels: list[Kernel] = []
_py = threading.local()


# ---------------------------------------------------------------- numba set-up
def cache_dir(numba_version: str) -> str:
    """The numba cache directory of this source tree: a hash of every ``rig_env/physics/*.py`` and numba's version."""
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    digest.update(numba_version.encode())
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "rig_env"
    return str(base / f"numba-{digest.hexdigest()[:16]}")


def setup_numba() -> Any:
    """Import numba, point its cache at :func:`cache_dir` (unless ``NUMBA_CACHE_DIR`` is set) and install the
    inliner fix (unless ``RIG_ENV_FAST_INLINE=0``); idempotent.  Returns the numba module."""
    global _numba
    with _setup_lock:
        if _numba is None:
            import numba

            if not os.environ.get("NUMBA_CACHE_DIR"):
                numba.config.CACHE_DIR = cache_dir(numba.__version__)
            _install_locator()
            if os.environ.get("RIG_ENV_FAST_INLINE", "1") != "0":
                from rig_env.physics import fast_inline

                fast_inline.install()
            _numba = numba
    return _numba


_PACKAGE_ROOT = Path(__file__).resolve().parents[1]  # the rig_env package directory


def package_subpath(py_file: str) -> str | None:
    """The cache subdirectory of a source file of rig_env: its directory inside the package, e.g.
    ``rig_env_physics``; None for a file outside the package."""
    try:
        rel = Path(py_file).resolve().parent.relative_to(_PACKAGE_ROOT)
    except ValueError:
        return None
    return "_".join(("rig_env",) + rel.parts)


def _install_locator() -> bool:
    """Put :class:`PackageCacheLocator` first among numba's cache locators (idempotent); False if numba's
    caching internals are not the ones this was written for (numba's own locators then serve)."""
    global PackageCacheLocator
    try:
        from numba.core import caching
        base = caching.UserProvidedCacheLocator
        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # renamed in numba 0.68
        classes = impl._locator_classes
    except (ImportError, AttributeError):
        return False
    if PackageCacheLocator is not None and PackageCacheLocator in classes:
        return True

    class _PackageCacheLocator(base):  # type: ignore[misc, valid-type]
        """numba's user-directory locator with the source's directory inside rig_env as the subpath."""

        @classmethod
        def get_suitable_cache_subpath(cls, py_file: str) -> str:
            return package_subpath(py_file) or base.get_suitable_cache_subpath(py_file)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if package_subpath(py_file) is None:
                return None
            return super().from_function(py_func, py_file)

    PackageCacheLocator = _PackageCacheLocator
    classes.insert(0, _PackageCacheLocator)
    return True


PackageCacheLocator: Any = None
"""numba cache locator for rig_env's sources (module docstring), created by :func:`setup_numba`."""


# ---------------------------------------------------------------- modes
def numba_available() -> bool:
    """Whether numba can be imported (looked up, not imported)."""
    return importlib.util.find_spec("numba") is not None


def mode() -> str:
    """``"numba"`` or ``"python"``: how kernels run in this process (module docstring)."""
    global _mode
    if _mode is None:
        env = os.environ.get("RIG_ENV_JIT", "").strip().lower()
        if env and env not in MODES:
            raise ValueError(f"RIG_ENV_JIT = {env!r}: expected one of {MODES}")
        _mode = env or ("numba" if numba_available() else "python")
    return _mode


def _set_mode(m: str | None) -> None:
    global _mode
    _mode = m
    for k in _kernels:
        k._target = k._first_call


def use_python() -> None:
    """Run every kernel as plain Python from its next call on (no numba import); the deploy loop's mode."""
    _set_mode("python")


def use_numba() -> None:
    """Compile every kernel with numba from its next call on (ImportError when numba is not installed)."""
    setup_numba()
    _set_mode("numba")


@contextlib.contextmanager
def python_mode() -> Iterator[None]:
    """``with python_mode():`` kernels run as Python inside, the mode of before (even undecided) after.

    What ``rig-deploy run`` wraps its loop in: the rig process never imports numba, and a caller that
    runs the command inside a process of its own (a test) gets its compiled kernels back."""
    before = _mode
    use_python()
    try:
        yield
    finally:
        _set_mode(before)


# ---------------------------------------------------------------- kernels
def _python_call(fn: Callable[..., Any]) -> Callable[..., Any]:
    """fn with numpy's floating-point warnings silenced around the outermost kernel call (numba's
    ``error_model="numpy"``: inf and NaN, no warning; wrapping uint64 arithmetic)."""

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> Any:
        if getattr(_py, "inside", False):
            return fn(*args, **kwargs)
        _py.inside = True
        try:
            with np.errstate(all="ignore"):
                return fn(*args, **kwargs)
        finally:
            _py.inside = False

    return call


def _numba_source(fn: Callable[..., Any], numba: Any) -> Callable[..., Any]:
    """fn, or for a kernel that uses ``prange`` a copy of it whose global ``prange`` is ``numba.prange``."""
    if "prange" not in fn.__code__.co_names or fn.__globals__.get("prange") is not range:
        return fn
    g = dict(fn.__globals__, prange=numba.prange)
    new = _pytypes.FunctionType(fn.__code__, g, fn.__name__, fn.__defaults__, fn.__closure__)
    new.__qualname__, new.__doc__, new.__module__ = fn.__qualname__, fn.__doc__, fn.__module__
    new.__kwdefaults__ = fn.__kwdefaults__
    return new


class Kernel:
    """A function compiled by numba at its first call (mode ``"numba"``) or run as Python (``"python"``).

    ``py_func``: the function; ``dispatcher``: the numba dispatcher (created, not compiled, on access).
    Other attributes (``signatures``, ``inspect_asm``...) are the dispatcher's."""

    def __init__(self, fn: Callable[..., Any], options: dict[str, Any], python: Callable[..., Any] | None = None) -> None:
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self.options = dict(options)
        self.python = python if python is not None else fn
        self._dispatcher: Any = None
        self._target: Callable[..., Any] = self._first_call
        _kernels.append(self)

    @property
    def dispatcher(self) -> Any:
        if self._dispatcher is None:
            numba = setup_numba()
            with _setup_lock:
                if self._dispatcher is None:
                    self._dispatcher = numba.njit(**self.options)(_numba_source(self.py_func, numba))
        return self._dispatcher

    def _first_call(self, *args: Any, **kwargs: Any) -> Any:
        self._target = self.dispatcher if mode() == "numba" else _python_call(self.python)
        return self._target(*args, **kwargs)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self._target(*args, **kwargs)

    # numba reads these when a kernel it compiles refers to this one (typing; the IR inliner)
    @property
    def _numba_type_(self) -> Any:
        return self.dispatcher._numba_type_

    @property
    def targetoptions(self) -> dict[str, Any]:
        return self.dispatcher.targetoptions

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name.startswith("_target") or name in ("_dispatcher", "py_func", "options", "python"):
            raise AttributeError(name)
        return getattr(self.dispatcher, name)

    def __deepcopy__(self, memo: dict[int, Any]) -> Kernel:  # numba deep-copies IR that refers to globals
        return self

    def __copy__(self) -> Kernel:
        return self

    def __repr__(self) -> str:
        return f"<rig_env kernel {self.__module__}.{self.__qualname__} ({mode() if _mode else 'mode not chosen'})>"


def kernel(fn: Callable[..., Any] | None = None, /, *, python: Callable[..., Any] | None = None, **numba_options: Any) -> Any:
    """Decorator: ``@kernel(cache=True, ...)`` (numba.njit's options) makes a lazily compiled :class:`Kernel`.

    python: what a call runs in Python mode (default: the function itself), for a function whose body
    numba compiles but Python cannot run for every input (e.g. ``math.floor`` of NaN)."""
    if fn is not None:
        return Kernel(fn, numba_options, python)
    return lambda f: Kernel(f, numba_options, python)


class Intrinsic:
    """``numba.extending.intrinsic(defn)`` created when numba first types a call to it; ``python`` in Python mode."""

    def __init__(self, defn: Callable[..., Any], python: Callable[..., Any]) -> None:
        functools.update_wrapper(self, python)
        self.defn, self.python = defn, python
        self._real: Any = None

    @property
    def real(self) -> Any:
        if self._real is None:
            setup_numba()
            from numba.extending import intrinsic as _intrinsic

            with _setup_lock:
                if self._real is None:
                    self._real = _intrinsic(self.defn)
        return self._real

    @property
    def _numba_type_(self) -> Any:
        from numba.core.registry import cpu_target

        ctx = cpu_target.typing_context
        real = self.real
        ctx.refresh()  # installs the template the intrinsic registered
        return ctx.resolve_value_type(real)

    def __call__(self, *args: Any) -> Any:
        return self.python(*args)

    def __deepcopy__(self, memo: dict[int, Any]) -> Intrinsic:
        return self

    def __copy__(self) -> Intrinsic:
        return self


def intrinsic(*, python: Callable[..., Any]) -> Callable[[Callable[..., Any]], Intrinsic]:
    """Decorator: a lazily created ``numba.extending.intrinsic`` with the Python twin ``python`` (required)."""
    return lambda defn: Intrinsic(defn, python)


# ---------------------------------------------------------------- Python twins of bit casts
_D = struct.Struct("<d")
_Q = struct.Struct("<q")


def bits_from_float(x: float) -> int:
    """The int64 holding the IEEE 754 bit pattern of the float64 ``x``."""
    return _Q.unpack(_D.pack(x))[0]


def float_from_bits(bits: int) -> float:
    """The float64 whose IEEE 754 bit pattern is the int64 ``bits``."""
    return _D.unpack(_Q.pack(int(bits)))[0]


__all__ = [
    "MODES", "Intrinsic", "Kernel", "PackageCacheLocator", "bits_from_float", "cache_dir", "float_from_bits", "intrinsic", "kernel", "mode",
    "numba_available", "package_subpath", "prange", "python_mode", "setup_numba", "use_numba", "use_python",
]
