"""The compile-time fix for numba's IR inliner (rig_env.physics.fast_inline): same code, no copies.

The fix only skips deep copies of a callee IR that numba made for one call site and drops afterwards.
These tests check that it is in effect, that code inlined through it (nested trees, several call sites
of one callee, branches, loops, tuples, closures over globals) computes what the plain Python functions
compute, and that a block's ordinary deep copy is untouched.  That the kernels compile to the same
numbers with and without it was checked bit for bit (benchmarks/RESULTS.md, "Cold compile").
"""

from __future__ import annotations

import copy
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from numba import njit
from numba.core import ir

import rig_env.physics  # noqa: F401  (installs the fix)
from rig_env.physics import fast_inline

_SCALE = 1.5


@njit(inline="always")
def _leaf(x):
    return x * _SCALE if x > 0.0 else -x


@njit(inline="always")
def _pair(x, y):
    s = 0.0
    for k in range(3):
        s += _leaf(x - k) + _leaf(y + k)
    return (s, _leaf(x) * _leaf(y))


@njit(inline="always")
def _mid(x, y):
    a, b = _pair(x, y)
    c, d = _pair(y, x)
    return a + b - c * d if a > c else math.sqrt(abs(a - c)) + _leaf(b)


@njit(cache=False)
def _top(xs):
    out = np.empty(xs.shape[0])
    for i in range(xs.shape[0]):
        out[i] = _mid(xs[i], 0.5 * xs[i]) + _mid(-xs[i], 2.0) + _leaf(xs[i])
    return out


def test_installed_in_this_process():
    if os.environ.get("RIG_ENV_FAST_INLINE", "1") == "0":
        pytest.skip("RIG_ENV_FAST_INLINE=0")
    assert fast_inline.installed()


def test_nested_inlined_tree_computes_what_python_computes():
    xs = np.linspace(-3.0, 3.0, 41)
    expected = np.array([_mid.py_func(x, 0.5 * x) + _mid.py_func(-x, 2.0) + _leaf.py_func(x) for x in xs])
    before = fast_inline.inlined
    got = _top(xs)  # compiles here: every inline site of the tree goes through the fix
    if fast_inline.installed():
        # _top: 2 x _mid + _leaf; each _mid: 2 x _pair + _leaf; each _pair: 4 x _leaf (two in the loop body)
        assert fast_inline.inlined - before == 3 + 2 * (3 + 2 * 4)
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-14)


def test_ordinary_block_deepcopy_is_a_real_copy():
    scope = ir.Scope(None, ir.Loc("f", 1))
    blk = ir.Block(scope, ir.Loc("f", 1))
    v = scope.define("x", ir.Loc("f", 1))
    blk.body.append(ir.Assign(ir.Const(1.0, ir.Loc("f", 1)), v, ir.Loc("f", 1)))
    new = copy.deepcopy(blk)
    assert new is not blk and new.body is not blk.body and new.body[0] is not blk.body[0]
    assert new.body[0].target.name == "x" and new.scope is not blk.scope


def test_switched_off_by_the_environment_variable():
    code = "import rig_env.physics; from rig_env.physics import fast_inline; print(fast_inline.installed())"
    env = dict(os.environ, RIG_ENV_FAST_INLINE="0")
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "False"
