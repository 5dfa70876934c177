"""rig_env.physics.jit: kernels compiled at first call or run as Python, the same numbers either way.

The rig process runs the sensors' and the task's kernels as Python (``rig-deploy run``); the
environments compile them.  A law must see the same float32 observation in both, so: the bit-cast
twins give numpy's bits, vmath's functions give numba's bits (inlined into a kernel without fast-math
flags, as the sensors inline them), and the observation builder gives identical observations over
random measurements, noise, quantisation, delays and every task.  Plus: the import side of the
design (gym ids in both import orders, the lazy public names, the numba set-up hook).
"""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from rig_env.envs import observation as ob
from rig_env.envs import streams as rs
from rig_env.envs.sensors import Sensors
from rig_env.envs.tasks import TASKS
from rig_env.params import JOINTS, RigParams, param_batch
from rig_env.physics import jit
from rig_env.physics import vmath as V

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
RNG = np.random.default_rng(2024)


python_mode = jit.python_mode


# ---------------------------------------------------------------- bit casts and vmath
def _specials() -> np.ndarray:
    return np.array([0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324, 2.2250738585072014e-308,
                     1.7976931348623157e308, np.pi, 1e-300, 123456.789])


def test_bit_cast_twins_are_numpy_views():
    x = np.concatenate([_specials(), RNG.standard_normal(2000) * 10.0 ** RNG.integers(-300, 300, 2000)])
    bits = x.view(np.int64)
    assert [jit.bits_from_float(float(v)) for v in x] == bits.tolist()
    back = np.array([jit.float_from_bits(int(b)) for b in bits])
    assert np.array_equal(back.view(np.int64), bits)
    assert V._bits_from_float(1.5) == np.float64(1.5).view(np.int64) and V._float_from_bits(4611686018427387904) == 2.0


@njit(cache=False)
def _vmath_all(x, y, out):
    """vmath inlined into a kernel without fast-math flags (as the sensors' kernels inline sincos)."""
    for i in range(x.shape[0]):
        s, c = V.sincos(x[i])
        out[0, i] = s
        out[1, i] = c
        out[2, i] = V.exp(x[i])
        out[3, i] = V.expm1(x[i])
        out[4, i] = V.log(abs(x[i]))
        out[5, i] = V.atan(x[i])
        out[6, i] = V.atan2(y[i], x[i])
        out[7, i] = V.asin(y[i] / (1.0 + abs(y[i])))


def _vmath_python(x, y):
    out = np.empty((8, x.size))
    with python_mode():
        for i, (a, b) in enumerate(zip(x.tolist(), y.tolist())):
            s, c = V.sincos(a)
            out[:, i] = (s, c, V.exp(a), V.expm1(a), V.log(abs(a)), V.atan(a), V.atan2(b, a), V.asin(b / (1.0 + abs(b))))
    return out


def test_vmath_as_python_gives_numbas_bits():
    x = np.concatenate([_specials(), RNG.uniform(-40.0, 40.0, 3000), RNG.standard_cauchy(1000), RNG.uniform(-1.0, 1.0, 1000) * 1e-8])
    y = RNG.standard_normal(x.size) * 3.0
    got = np.empty((8, x.size))
    _vmath_all(x, y, got)
    want = _vmath_python(x, y)
    bad = ~((got == want) | (np.isnan(got) & np.isnan(want)))
    bad[:2] &= ~(np.isfinite(x) & (np.abs(x) > V.SINCOS_MAX))  # sincos beyond its domain (2^30 rad): garbage either way
    assert not bad.any(), f"{bad.sum()} differ, e.g. function {np.argwhere(bad)[0]}"


# ---------------------------------------------------------------- observations
def _observations(joints, n, steps, delay, quantise, noisy, seed):
    rng = np.random.default_rng(seed)
    sensors = Sensors(n, joints, 1.0 / 80.0, delay_steps=delay, quantise=quantise, angle_noise=1e-3, flap_noise=2e-3, airspeed_noise=0.1)
    nj = len(joints)
    sensors.reset(np.arange(n), rng.uniform(-1, 1, (n, nj)), rng.uniform(-0.5, 0.5, (n, 4)), rng.uniform(10, 30, n))
    out = []
    for k in range(steps):
        angles = rng.uniform(-3.5, 3.5, (n, nj)) * (1.0 + 40.0 * (k % 5 == 0))  # some beyond the bounds: clipped
        noise = rs.normal(rs.env_keys(seed, n), 0, k, rs.S_SENSOR, sensors.n_channels) if noisy else None
        sensors.update(angles, rng.uniform(-1, 1, (n, 4)), rng.uniform(0, 70, n), noise)
        obs = np.empty((n, sensors.obs_dim), dtype=np.float32)
        sensors.observation(out=obs)
        out.append((obs, sensors.observation(), sensors.rates.copy()))
    return out


@pytest.mark.parametrize("joints", [("rig_roll", "model_pitch"), JOINTS, ("rig_pitch", "model_pitch"), ("rig_yaw", "model_yaw")])
@pytest.mark.parametrize("delay,quantise,noisy", [(0, False, False), (2, True, True)])
def test_sensor_observations_identical_in_python_and_numba(joints, delay, quantise, noisy):
    seed = 11 + delay
    numba_obs = _observations(joints, 7, 12, delay, quantise, noisy, seed)
    with python_mode():
        py_obs = _observations(joints, 7, 12, delay, quantise, noisy, seed)
    for (a32, a64, ar), (b32, b64, br) in zip(numba_obs, py_obs):
        assert np.array_equal(a32.view(np.int32), b32.view(np.int32))
        assert np.array_equal(a64, b64) and np.array_equal(ar, br)


def _task_run(name, seed):
    cls = TASKS[name]
    free = cls.free_dofs_for({})
    dt = 1.0 / 80.0
    row = param_batch(RigParams.default(), 1)
    task = ob.task_for_seed(name, free, dt, 20.0, seed, params_row=row)
    sensors = Sensors(1, free, dt, quantise=False)
    rng = np.random.default_rng(seed)
    out = []
    q5, qd5 = np.zeros((1, 5)), np.zeros((1, 5))
    free_idx = [JOINTS.index(j) for j in free]
    for k in range(60):
        sensors.update(rng.uniform(-0.6, 0.6, (1, len(free))), rng.uniform(-0.3, 0.3, (1, 4)), np.array([18.0 + rng.uniform()]))
        t = np.array([k * dt + 0.5])
        q5[0, free_idx] = sensors.angles[0]
        qd5[0, free_idx] = sensors.rates[0]
        task.advance(t, q5, qd5)
        out.append(ob.observe(sensors, task, t))
    return np.array(out)


@pytest.mark.parametrize("name", sorted(TASKS))
def test_task_observations_identical_in_python_and_numba(name):
    a = _task_run(name, 3)
    with python_mode():
        b = _task_run(name, 3)
    assert a.dtype == np.float32 and np.array_equal(a.view(np.int32), b.view(np.int32))


def test_python_mode_streams_are_numbas():
    keys = rs.env_keys(99, 9)
    a = rs.uniform(keys, 1, 7, rs.S_REFERENCE, 5)
    with python_mode():
        b = rs.uniform(keys, 1, 7, rs.S_REFERENCE, 5)
        c = rs.normal(keys, 1, 7, rs.S_SENSOR, 3)
    assert np.array_equal(a, b)
    np.testing.assert_allclose(c, rs.normal(keys, 1, 7, rs.S_SENSOR, 3), rtol=0, atol=1e-14)  # numba's: fast-math flags


def test_kernel_is_lazy_and_keeps_its_function():
    k = V.sincos
    assert isinstance(k, jit.Kernel) and k.__name__ == "sincos" and k.__doc__ == k.py_func.__doc__
    assert inspect.signature(k) == inspect.signature(k.py_func)
    assert k.targetoptions["inline"] == "always"  # what numba's IR inliner reads
    assert copy_is_self(k)


def copy_is_self(k) -> bool:
    import copy

    return copy.deepcopy(k) is k and copy.copy(k) is k


# ---------------------------------------------------------------- the import side (fresh interpreters)
def _run(code: str, env: dict | None = None, timeout: float = 600) -> str:
    r = subprocess.run([sys.executable, "-c", code], env=env or ENV, capture_output=True, text=True, timeout=timeout, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr[-4000:]
    return r.stdout.strip().splitlines()[-1]


def test_python_mode_by_environment_variable_imports_no_numba():
    code = ("import sys, json, numpy as np; from rig_env.envs.sensors import Sensors; from rig_env.physics import jit\n"
            "s = Sensors(2, ('rig_roll', 'model_pitch'), 0.0125); s.update(np.ones((2, 2)), np.zeros((2, 4)), np.full(2, 20.0))\n"
            "o = s.observation(); print(json.dumps([jit.mode(), 'numba' in sys.modules, 'llvmlite' in sys.modules, o.shape[1]]))")
    assert json.loads(_run(code, dict(ENV, RIG_ENV_JIT="python"))) == ["python", False, False, 10]


@pytest.mark.parametrize("order", ["gymnasium first", "rig_env first"])
def test_gym_ids_registered_in_either_import_order(order):
    first = ("import gymnasium as gym; import rig_env\n" if order == "gymnasium first" else
             "import sys; import rig_env; assert 'gymnasium' not in sys.modules and 'numba' not in sys.modules; import gymnasium as gym\n")
    code = (first + "import json, sys; from rig_env import importhook\n"
            "env = gym.make('rig_env/BankToBank-v0'); obs, _ = env.reset(seed=0)\n"
            "print(json.dumps([obs.shape[0], sorted(i for i in gym.registry if i.startswith('rig_env/')), list(importhook.waiting()),"
            " any(type(f).__module__ == 'rig_env.importhook' for f in sys.meta_path)]))")
    dim, ids, waiting, hooked = json.loads(_run(code))
    assert dim > 0 and len(ids) == 7 and waiting == [] and not hooked  # both hooks fired and the finder removed itself


def test_lazy_public_names_are_the_real_functions():
    code = ("import json, inspect, sys; import rig_env\n"
            "light = [m for m in ('rig_env.simulate', 'rig_env.linear', 'numba', 'gymnasium') if m in sys.modules]\n"
            "import rig_env.envs.vector_env  # imports the submodule rig_env.simulate first\n"
            "from rig_env.simulate import simulate as f; from rig_env.linear import trim; from rig_env import SimResult\n"
            "from rig_env.physics import fast_inline; import numba\n"
            "print(json.dumps([light, rig_env.simulate is f, rig_env.trim is trim, SimResult.__module__, str(inspect.signature(rig_env.trim)) == str(inspect.signature(trim)),"
            " fast_inline.installed(), numba.config.CACHE_DIR.rsplit('/', 1)[-1].startswith('numba-'), sys.modules['rig_env.simulate'].__name__]))")
    light, same_sim, same_trim, mod, same_sig, fixed, cache, name = json.loads(_run(code))
    assert light == [] and same_sim and same_trim and mod == "rig_env.simulate" and same_sig and name == "rig_env.simulate"
    assert cache and (fixed or os.environ.get("RIG_ENV_FAST_INLINE") == "0")


def test_python_mode_restores_the_mode_of_before():
    before = jit.mode()
    with jit.python_mode():
        assert jit.mode() == "python" and V.sincos._target is not V.sincos.dispatcher
        V.sincos(0.5)
    assert jit.mode() == before
    V.sincos(0.5)
    assert (V.sincos._target is V.sincos.dispatcher) == (before == "numba")
