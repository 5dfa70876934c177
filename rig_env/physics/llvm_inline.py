"""The right-hand side's parts inlined by LLVM, not by numba: each part compiled once, not once per call site.

The kernels are written as small functions (a strip's aerodynamics, a joint's friction, the mass
matrix) that must end up inside their callers' loops: as separate functions they exchange their tuples
through memory and a call inside a loop over the lanes stops LLVM vectorising it (:mod:`lanes`).
numba's own ``inline="always"`` does this at numba-IR level: every call site translates, types and
lowers the callee again, in Python, so a cold compile grew with the number of call sites (the lane
kernel has ten copies of a joint's friction, each with the right-hand side's parameters) and the IR
passes that are quadratic in a function's size (SSA reconstruction, liveness) ran on the inlined whole.
Profiled on a cold compile of the lane kernel (numba 0.68, Zen 4): 113 s, of which LLVM about a tenth.

:func:`inlined` instead compiles the function once per argument *type* (never per constant: numba types
a constant argument as a literal and would compile a copy per joint index) as an ordinary numba
function whose LLVM definition carries ``alwaysinline``: LLVM's inliner puts it into every caller when
the caller's module is optimised (numba links a callee into its caller's module, with ``linkonce_odr``
linkage, before that optimisation), and the constants of each call site are then folded by LLVM as
numba would have folded them.  The machine code is the same in kind: the lane kernel still runs every
lane loop as 512-bit vector operations (``benchmarks/RESULTS.md``: the same env-steps/s), and the cold
compile of the lane kernel falls by about half.

:func:`install` adds the attribute as numba hands a function's LLVM IR to its code library (a patch of
``CPUCodeLibrary.add_ir_module``, matched on the mangled name of every function :func:`inlined`
registered).  If numba's internals are not the ones this was written against, or ``RIG_ENV_LLVM_INLINE=0``
is set (for a comparison, ``benchmarks/bench_compile.py``), :func:`inlined` falls back to numba's
``inline="always"`` (slower to compile, the same results to rounding).  The disk cache keeps the attribute:
a callee's module for linking is stored as LLVM bitcode with it.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from typing import Any

_prefixes: set[str] = set()
_installed: bool | None = None


def mangled_prefix(module: str, qualname: str) -> str:
    """The start of numba's (Itanium) mangled name of ``module.qualname``: ``_ZN`` and each dotted part
    prefixed by its length, e.g. ``_ZN7rig_env7physics5lanes10rhs_values`` (the ABI tags and argument types follow)."""
    parts = f"{module}.{qualname}".split(".")
    return "_ZN" + "".join(f"{len(p)}{p}" for p in parts)


def _is_registered(name: str) -> bool:
    # the mangled name continues with "B" (ABI tags) or "E" (end of the nested name) after the function's name
    for prefix in _prefixes:
        if name.startswith(prefix) and name[len(prefix) : len(prefix) + 1] in ("B", "E"):
            return True
    return False


def install() -> bool:
    """Patch numba's code library to mark registered functions ``alwaysinline`` (idempotent); False if
    numba's internals differ from what this was written for (then :func:`inlined` uses numba's IR inliner)."""
    global _installed
    if _installed is not None:
        return _installed
    if os.environ.get("RIG_ENV_LLVM_INLINE", "1") == "0":
        _installed = False
        return False
    try:
        from numba.core import codegen
        from numba.core.dispatcher import Dispatcher
    except ImportError:
        _installed = False
        return False
    lib = getattr(codegen, "CPUCodeLibrary", None)
    if lib is None or not hasattr(lib, "add_ir_module") or not hasattr(Dispatcher, "get_call_template"):
        _installed = False
        return False
    original = lib.add_ir_module

    @functools.wraps(original)
    def add_ir_module(self: Any, ir_module: Any) -> Any:
        for fn in ir_module.functions:
            if fn.blocks and _is_registered(fn.name) and "alwaysinline" not in fn.attributes:
                fn.attributes.add("alwaysinline")
        return original(self, ir_module)

    lib.add_ir_module = add_ir_module
    _installed = True
    return True


def _unliteral_template(dispatcher: Any) -> Callable[..., Any]:
    """``dispatcher.get_call_template`` that types constant arguments as their plain types (one compile per
    argument type); the literal types only where the function cannot be typed without them."""
    from numba.core import errors, types

    original = dispatcher.get_call_template

    def get_call_template(args: tuple[Any, ...], kws: dict[str, Any]) -> Any:
        plain = tuple(types.unliteral(a) for a in args)
        plain_kws = {k: types.unliteral(v) for k, v in kws.items()}
        if plain == tuple(args) and plain_kws == kws:
            return original(args, kws)
        try:
            return original(plain, plain_kws)
        except errors.TypingError:
            return original(args, kws)

    return get_call_template


def inlined(*, ir_fallback: bool = True, **options: Any) -> Callable[[Callable[..., Any]], Any]:
    """Decorator: ``numba.njit(**options)`` of a function that LLVM inlines into every compiled caller
    (module docstring).  When :func:`install` cannot patch numba (or ``RIG_ENV_LLVM_INLINE=0``): numba's
    ``inline="always"`` with ``ir_fallback``, else a plain ``numba.njit`` (that LLVM may inline by its own
    cost model; the small friction and servo functions, which were never inlined by numba)."""
    import numba

    def wrap(fn: Callable[..., Any]) -> Any:
        if not install():
            return numba.njit(**options, inline="always")(fn) if ir_fallback else numba.njit(**options)(fn)
        _prefixes.add(mangled_prefix(fn.__module__, fn.__qualname__))
        dispatcher = numba.njit(**options)(fn)
        dispatcher.get_call_template = _unliteral_template(dispatcher)
        return dispatcher

    return wrap


__all__ = ["inlined", "install", "mangled_prefix"]
