"""Run a function right after a module is imported, without importing it: :func:`when_imported`.

``import rig_env`` must not import gymnasium or numba (the rig's real-time loop runs without both), yet
two things have to happen as soon as either is imported in the same process, whichever comes first:

* gymnasium: the ``rig_env/*`` ids are registered (:mod:`rig_env.envs.registration`), so that
  ``import rig_env; import gymnasium as gym; gym.make("rig_env/BankToBank-v0")`` works;
* numba: its cache directory and the inliner fix are set up (:func:`rig_env.physics.jit.setup_numba`)
  before any kernel is decorated or compiled.

:func:`when_imported` calls the function at once when the module is already in ``sys.modules``;
otherwise it puts a finder at the front of ``sys.meta_path`` that, when the module is imported, lets
the ordinary finders find it and wraps that one loader's ``exec_module`` so that the function runs
right after the module's code (the loader and the module are otherwise untouched).  The finder removes
itself once every module it waits for has been imported.  Standard library only.
"""

from __future__ import annotations

import importlib.abc
import sys
import threading
import warnings
from collections.abc import Callable
from types import ModuleType

_lock = threading.RLock()
_waiting: dict[str, list[Callable[[], None]]] = {}


class _Finder(importlib.abc.MetaPathFinder):
    """Finds nothing itself: for a waited-for module, the spec the other finders return, its loader wrapped."""

    def find_spec(self, fullname, path, target=None):  # noqa: D102
        if fullname not in _waiting:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None:
                break
        else:
            return None
        loader = spec.loader
        if loader is None or not hasattr(loader, "exec_module"):
            return spec
        original = loader.exec_module

        def exec_module(module: ModuleType) -> None:
            try:
                original(module)
            finally:
                try:
                    del loader.exec_module  # the instance attribute set below: the class's method again
                except AttributeError:
                    pass
            _fire(fullname)

        loader.exec_module = exec_module  # this loader instance only (one per module)
        return spec


_finder = _Finder()


def _fire(name: str) -> None:
    with _lock:
        callbacks = _waiting.pop(name, [])
        if not _waiting and _finder in sys.meta_path:
            sys.meta_path.remove(_finder)
    for cb in callbacks:
        try:
            cb()
        except Exception as e:  # noqa: BLE001 - never break the import that triggered it
            warnings.warn(f"rig_env: after importing {name}: {cb.__qualname__} failed: {type(e).__name__}: {e}", RuntimeWarning, stacklevel=2)


def when_imported(name: str, callback: Callable[[], None]) -> None:
    """Call ``callback()`` now if module ``name`` (top-level) is imported, else right after its import.

    A failed import leaves the callback waiting for the next attempt.  Each callback runs once."""
    with _lock:
        if name not in sys.modules:
            _waiting.setdefault(name, []).append(callback)
            if _finder not in sys.meta_path:
                sys.meta_path.insert(0, _finder)
            return
    callback()


def waiting() -> tuple[str, ...]:
    """Modules with callbacks still waiting for their import (for tests and diagnostics)."""
    with _lock:
        return tuple(_waiting)


__all__ = ["waiting", "when_imported"]


def lazy_attributes(package: str, lazy: dict[str, str], namespace: dict) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package`` (PEP 562): each name of ``lazy`` is imported from its
    module (``lazy[name]``) at its first use and then bound in ``namespace`` (the package's globals)."""

    def __getattr__(name: str) -> object:
        module = lazy.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        import importlib

        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(lazy))

    return __getattr__, __dir__
