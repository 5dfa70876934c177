"""Compile-time fix for numba's IR inliner: no defensive copies of a callee IR made for one call site.

The small helpers that are still inlined at numba-IR level (``inline="always"``: :mod:`vmath`, :mod:`vec`,
the lane kernel's generated loads and stores; the right-hand side's larger parts are inlined by LLVM,
:mod:`rig_env.physics.llvm_inline`, and with ``RIG_ENV_LLVM_INLINE=0`` by numba, in trees several levels
deep) go through numba's IR inliner.  For every call site numba's ``InlineWorker.inline_function``
translates the callee afresh (``run_untyped_passes``, which inlines the callee's own callees) and hands
that new IR to ``inline_ir``, which deep-copies it twice before use: once to mutate, once to return an
unmutated original that this caller throws away.  The copies are made block by block, each with its own
memo, so the callee's whole variable scope is copied again for every block: quadratic in the size of
the callee.  Profiled on a cold compile of the lane kernel with every part IR-inlined (numba 0.68): 294 s of 386 s in those copies
(``copy.deepcopy``, 120 million calls), 10 s in LLVM.  numba's own fix of these spurious deep copies removed one of three; the two left
remain.

:func:`install` makes ``inline_function`` call ``inline_ir`` with a thread-local flag set, under which
``ir.Block.__deepcopy__`` returns the block itself: the IR that call made is mutated in place and
dropped afterwards, exactly as the copy would have been.  Every other deep copy of a block (other
passes, ``inline_ir`` called from elsewhere, e.g. for ``@overload(inline="always")`` with its cached
IR) is the ordinary one.  The compiled code is the same; only the copying is skipped.  Installed when
:mod:`rig_env.physics` is imported, unless ``RIG_ENV_FAST_INLINE=0`` is set or numba's internals are not
the ones this was written against (then numba is left as it is).
"""

from __future__ import annotations

import copy
import threading

_state = threading.local()
_installed = False
inlined = 0
"""Call sites inlined through the fix in this process (for tests and diagnostics)."""


def _fresh() -> bool:
    return getattr(_state, "fresh", False)


def _block_deepcopy(self, memo):
    """``copy.deepcopy`` of an ``ir.Block``: the block itself while a fresh callee IR is being inlined,
    else the ordinary deep copy (a new block with every attribute deep-copied under ``memo``)."""
    if _fresh():
        return self
    new = self.__class__.__new__(self.__class__)
    memo[id(self)] = new
    for k, v in self.__dict__.items():
        setattr(new, k, copy.deepcopy(v, memo))
    return new


def install() -> bool:
    """Install the fix (idempotent); False if numba's internals differ from what it was written for."""
    global _installed
    if _installed:
        return True
    try:
        from numba.core import ir
        from numba.core.inline_closurecall import InlineWorker
    except ImportError:
        return False
    needed = all(hasattr(InlineWorker, a) for a in ("inline_function", "inline_ir", "run_untyped_passes"))
    if not needed or "__deepcopy__" in vars(ir.Block):
        return False

    def inline_function(self, caller_ir, block, i, function, arg_typs=None):
        global inlined
        callee_ir = self.run_untyped_passes(function)  # new IR, for this call site only
        inlined += 1
        previous = _fresh()
        _state.fresh = True
        try:
            return self.inline_ir(caller_ir, block, i, callee_ir, function.__code__.co_freevars, arg_typs=arg_typs)
        finally:
            _state.fresh = previous

    inline_function.__doc__ = InlineWorker.inline_function.__doc__
    ir.Block.__deepcopy__ = _block_deepcopy
    InlineWorker.inline_function = inline_function
    _installed = True
    return True


def installed() -> bool:
    """Whether the fix is in effect in this process."""
    return _installed
