"""Env-step throughput of rig_env's kernels against its peers, measured in one run.

One env-step = one 80 Hz control step = 5 physics steps of 2.5 ms, all physics on (aero at 20 m/s,
LuGre friction, stops, servos), all five joints free.  Measured:

* the joint-space model in SIMD lanes (``rig_env.physics.lanes.step_lanes``, eight environments per
  register: what the environments run), the same model one environment per ``prange`` iteration
  (``rig_env.physics.integrator.step_batch``, "joint") and, when present, the DAE kernel
  (``rig_env.physics.dae.step_batch_dae``, plus its conversion to joint space after every step),
  each through ``rig_env.physics.pipeline.PhysicsBatch.step`` (one kernel call, no other Python
  bookkeeping per step) at batch sizes 1, 64, 1024, 4096, 16384 (``--quick``: up to 4096, shorter windows), each through
  the serial twin below ``integrator.PARALLEL_MIN_ENVS`` environments as rig_env itself does; the
  best wall rate of three windows, and the rate per CPU-second (``env_steps_per_cpu_s``, which other
  jobs on a shared machine do not inflate);
* JIT compile time of the lane kernel and of the per-environment kernel, each in a fresh subprocess
  with an empty numba cache directory, and the load time from that cache in a second subprocess;
* the peers, in the same run:

  - **scipy solve_ivp + numpy RHS** (what a researcher would otherwise write; the issue's reference):
    ``rig_env.numpy_model.rhs``, the same continuous model written in plain numpy (explicit body
    Jacobians, ``numpy.linalg.solve``; checked against the kernel to 1e-14 by
    tests/test_numpy_model.py), under ``solve_ivp`` Radau, RK45 and BDF as an ordinary 1-D function
    (the implicit methods form their Jacobian by finite differences);
  - **scipy solve_ivp + rig_env's compiled RHS**: the same calls on ``rig_env.reference.continuous_rhs``,
    which evaluates the numba kernel's accelerations (``vectorized`` for the implicit methods): a
    right-hand side no researcher would have, shown to separate the integrator's cost from the
    right-hand side's;
  - MuJoCo stepped from Python with aero applied each physics step (no friction, stops or servos;
    benchmarks/mujoco_ref.py), 1 and a few envs.

  Every solve_ivp peer: one env, all five joints free, aero at 20 m/s, friction, stops, ideal servos
  (surfaces at the command, here zero), rtol 1e-6, atol 1e-8, one ``solve_ivp`` call per 12.5 ms
  env-step from the previous end state, timed over the same segment (the first 80 env-steps = 1 s
  of simulated time from one state near trim, ``--quick`` 16), rate = env-steps / wall time.  Their
  cost depends on the state (stiff bristles while the joints slide, a fraction of it once the rig
  has come to rest after about 20 s), hence one fixed segment for all of them;
* ``speedup_vs_scipy`` = lane-kernel rate at 4096 envs over the best numpy-RHS solve_ivp rate,
  ``speedup_vs_scipy_compiled_rhs`` over the best compiled-RHS one, ``speedup_vs_mujoco`` over the
  best MuJoCo + Python aero rate.

Usage: ``python benchmarks/bench_step.py [--quick] [--json]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rig_env import RigParams, param_batch  # noqa: E402
from rig_env.physics import layout as L  # noqa: E402
from rig_env.physics.pipeline import PhysicsBatch, flags_of  # noqa: E402

H = 0.0025  # physics step, s
N_SUB = 5  # physics steps per env-step
AIRSPEED = 20.0  # m/s
FLAGS = flags_of(aero=True, friction=True, stops=True, servo=True, nonlinear_aero=False)


def machine() -> dict:
    """CPU model, logical CPUs available to this process, numba threads, load at start."""
    model = platform.processor() or "unknown"
    fields: dict[str, str] = {}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            fields.setdefault(key.strip(), value.strip())
            if not line.strip():
                break  # the first processor's block
    except OSError:
        pass
    model = fields.get("model name", model)
    if "cpu family" in fields and "model" in fields:  # the generation, which a bare "AMD EPYC" does not tell
        model += f" (family {fields['cpu family']} model {fields['model']})"
    import numba

    return {
        "cpu": model,
        "cpus_available": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
        "numba_threads": int(numba.config.NUMBA_NUM_THREADS),
        "load_average_at_start": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "python": platform.python_version(),
        "numba": numba.__version__,
    }


def machine_line() -> str:
    """:func:`machine` as the one-line header the benchmarks print above their tables."""
    m = machine()
    load = f"{m['load_average_at_start'][0]:.2f}" if m["load_average_at_start"] else "unknown"
    return (f"{m['cpu']}, {m['cpus_available']} CPUs, numba {m['numba']} with {m['numba_threads']} threads, "
            f"Python {m['python']}, load average {load} at start")


def at_least_one(text: str) -> int:
    """argparse type of the benchmarks' counts (rounds, repeats): an integer >= 1."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def setup(params: RigParams, n: int, seed: int = 0) -> dict:
    """A physics batch of n environments near trim (all joints free, servos at rest at zero, AIRSPEED):
    ``batch`` (:class:`rig_env.physics.pipeline.PhysicsBatch`) and its arrays ``X``, ``P``, ``U``, ``status``."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.2, 0.2, (n, 5))
    qd = rng.uniform(-0.5, 0.5, (n, 5))
    batch = PhysicsBatch(param_batch(params, n), params.tables(), np.arange(5, dtype=np.int64), FLAGS, H, N_SUB, kind="joint")
    batch.reset(np.arange(n), q, qd)
    batch.U[:, L.U_AIRSPEED] = AIRSPEED
    return dict(batch=batch, X=batch.X, P=batch.P, U=batch.U, status=batch.status)


def _stepper(a: dict, kind: str):
    """One env-step of every environment of setup's batch on the kernel of ``kind``, in its serial twin below
    ``integrator.PARALLEL_MIN_ENVS`` environments as rig_env itself does (``pipeline.choose_kernel``)."""
    batch: PhysicsBatch = a["batch"]
    batch.select_kernel(kind)
    return batch.step


def joint_stepper(a: dict):
    """One env-step of every environment with the per-environment kernel (``integrator.step_batch``)."""
    return _stepper(a, "joint")


def lanes_stepper(a: dict):
    """The same env-step with the lane kernel (eight environments per SIMD register), as the environments use it."""
    return _stepper(a, "lanes")


def dae_stepper(a: dict):
    """The same env-step with the DAE kernel (its state starts from setup's joint state)."""
    return _stepper(a, "dae")


def rate(step, n: int, seconds: float, min_calls: int = 3, repeats: int = 3) -> tuple[float, float]:
    """(wall, CPU) env-steps/s of ``step`` (one env-step of n envs per call) over about ``seconds``.

    The window is split into ``repeats`` parts and the best wall rate is kept: on a shared machine the
    other jobs only ever slow a part down.  The CPU rate divides by the process's CPU time (all numba
    threads), which another job's load does not inflate: with T threads busy it is about the wall
    rate / T on idle cores.
    """
    step()  # warm-up (and compile or cache load)
    best = 0.0
    calls_all = 0
    cpu_all = 0.0
    for _ in range(repeats):
        calls = 0
        c0 = time.process_time()
        t0 = time.perf_counter()
        while True:
            step()
            calls += 1
            elapsed = time.perf_counter() - t0
            if elapsed >= seconds / repeats and calls >= min_calls:
                break
        cpu_all += time.process_time() - c0
        calls_all += calls
        best = max(best, calls * n / elapsed)
    return best, calls_all * n / cpu_all


_COMPILE_SNIPPET = """
import json, sys, time
t0 = time.perf_counter()
import numpy as np
from rig_env import RigParams
import benchmarks.bench_step as b
t1 = time.perf_counter()
a = b.setup(RigParams.default(), 64)  # the parallel kernel, as at 4096 envs
step = getattr(b, sys.argv[1])(a)
t2 = time.perf_counter()
step()
t3 = time.perf_counter()
step()
t4 = time.perf_counter()
out = {"import_s": t1 - t0, "first_call_s": t3 - t2, "second_call_s": t4 - t3}
if len(sys.argv) > 2:  # env-steps/s on 1024 environments
    a = b.setup(RigParams.default(), 1024)
    out["rate"] = b.rate(getattr(b, sys.argv[1])(a), 1024, 3.0)[0]
print(json.dumps(out))
"""


def compile_times(stepper: str = "lanes_stepper", extra_env: dict[str, str] | None = None, rate: bool = False) -> dict:
    """First-call time of a kernel in fresh interpreters: empty numba cache, then warm cache.
    extra_env: more environment variables for both interpreters (e.g. ``RIG_ENV_LLVM_INLINE``); rate: also
    the kernel's env-steps/s on 1024 environments, measured in the warm interpreter (key ``rate``)."""
    out = {}
    with tempfile.TemporaryDirectory(prefix="rig_bench_numba_") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), **(extra_env or {}))
        for label in ("cold", "cached"):
            extra = ["rate"] if rate and label == "cached" else []
            r = subprocess.run([sys.executable, "-c", _COMPILE_SNIPPET, stepper, *extra], env=env, cwd=ROOT, capture_output=True, text=True, timeout=900)
            if r.returncode != 0:
                raise RuntimeError(f"compile subprocess failed: {r.stderr[-2000:]}")
            out[label] = json.loads(r.stdout.strip().splitlines()[-1])
    return {
        "compile_s": out["cold"]["first_call_s"],
        "cached_load_s": out["cached"]["first_call_s"],
        "import_s": out["cold"]["import_s"],
        **({"rate": out["cached"]["rate"]} if rate else {}),
    }


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="batches 1..4096, short timing windows (< 1 min)")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    args = ap.parse_args(argv)
    batches = (1, 64, 1024, 4096) if args.quick else (1, 64, 1024, 4096, 16384)
    window = 0.3 if args.quick else 2.0
    peer_window = 0.7 if args.quick else 3.0
    log = (lambda *a: print(*a, file=sys.stderr)) if args.json else print
    params = RigParams.default()
    info = machine()
    log(f"machine: {info['cpu']}, {info['cpus_available']} CPUs available, numba threads {info['numba_threads']}, load {info['load_average_at_start']}")

    results: dict[str, dict[str, float]] = {}
    cpu_results: dict[str, dict[str, float]] = {}
    notes: dict[str, str] = {}
    failed: dict[str, dict[str, int]] = {}
    for name, make in (("lanes", lanes_stepper), ("joint", joint_stepper), ("dae", dae_stepper)):
        results[name] = {}
        cpu_results[name] = {}
        failed[name] = {}
        for n in batches:
            try:
                a = setup(params, n)
                step = make(a)
                results[name][str(n)], cpu_results[name][str(n)] = rate(step, n, window)
                failed[name][str(n)] = int(np.count_nonzero(a["status"]))
            except (ImportError, AttributeError) as exc:
                notes[name] = f"not available: {type(exc).__name__}: {exc}"
                break
            except Exception as exc:  # a kernel under concurrent development may not compile
                notes[name] = f"failed: {type(exc).__name__}: {str(exc).splitlines()[0][:300]}"
                break
            log(f"{name:6s} {n:6d} envs: {results[name][str(n)]:14,.0f} env-steps/s  ({cpu_results[name][str(n)]:,.0f} per CPU-second; {failed[name][str(n)]} envs flagged)")
        if name in notes:
            log(f"{name}: {notes[name]}")
            if not results[name]:
                del results[name]
                del cpu_results[name]

    compile_info = compile_times("lanes_stepper")
    log(f"lane kernel JIT: compile {compile_info['compile_s']:.2f} s cold, {compile_info['cached_load_s']:.2f} s from cache")
    joint_compile = compile_times("joint_stepper")
    log(f"per-environment kernel JIT: compile {joint_compile['compile_s']:.2f} s cold, {joint_compile['cached_load_s']:.2f} s from cache")

    from rig_env.reference import env_steps_per_s_scipy, env_steps_per_s_scipy_numpy

    segment = 16 if args.quick else 80  # env-steps of every solve_ivp peer, from the same state
    methods = ("Radau", "RK45", "BDF")
    scipy_numpy = {m: env_steps_per_s_scipy_numpy(params, segment, m) for m in methods}
    for m, v in scipy_numpy.items():
        log(f"scipy solve_ivp {m:5s} + numpy RHS (what a researcher would otherwise write; 1 env, rtol 1e-6, {segment} env-steps): {v:10,.1f} env-steps/s")
    scipy_compiled = {m: env_steps_per_s_scipy(params, segment, m) for m in methods}
    for m, v in scipy_compiled.items():
        log(f"scipy solve_ivp {m:5s} + rig_env's compiled RHS (1 env, rtol 1e-6, {segment} env-steps): {v:10,.1f} env-steps/s")

    mujoco_rates: dict[str, float] = {}
    try:
        from benchmarks.mujoco_ref import mujoco_env_steps_per_s, mujoco_rollout_env_steps_per_s

        for n in (1, 8):
            mujoco_rates[f"python_aero_{n}env"] = mujoco_env_steps_per_s(params, n, peer_window)
            log(f"MuJoCo + Python aero, {n} env(s): {mujoco_rates[f'python_aero_{n}env']:10,.0f} env-steps/s")
        if not args.quick:
            mujoco_rates["rollout_bare_mechanism_4096env"] = mujoco_rollout_env_steps_per_s(params, 4096, peer_window)
            log(f"MuJoCo rollout, bare mechanism (no aero/friction), 4096 envs: {mujoco_rates['rollout_bare_mechanism_4096env']:10,.0f} env-steps/s")
    except ImportError as exc:
        notes["mujoco"] = f"not available: {exc}"

    ref = results["lanes"].get("4096")
    best_scipy = max(scipy_numpy.values())
    best_scipy_compiled = max(scipy_compiled.values())
    aero_peers = [v for k, v in mujoco_rates.items() if k.startswith("python_aero")]
    out = {
        "env_steps_per_s": results,
        "env_steps_per_cpu_s": cpu_results,
        "compile_s": compile_info["compile_s"],
        "cached_load_s": compile_info["cached_load_s"],
        "compile_s_per_env_kernel": joint_compile["compile_s"],
        "speedup_vs_scipy": ref / best_scipy if ref else None,
        "speedup_vs_scipy_compiled_rhs": ref / best_scipy_compiled if ref else None,
        "speedup_vs_mujoco": ref / max(aero_peers) if ref and aero_peers else None,
        "scipy_numpy_rhs_env_steps_per_s": scipy_numpy,
        "scipy_compiled_rhs_env_steps_per_s": scipy_compiled,
        "scipy_segment_env_steps": segment,
        "mujoco_env_steps_per_s": mujoco_rates,
        "envs_flagged": failed,
        "notes": notes,
        "machine": info,
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
        "env_step": f"{N_SUB} x {H * 1e3:g} ms physics steps, aero {AIRSPEED:g} m/s + friction + stops + servos, 5 joints free",
    }
    if ref:
        log(
            f"speedup at 4096 envs: {out['speedup_vs_scipy']:,.0f}x scipy + numpy RHS (best of {'/'.join(methods)}), "
            f"{out['speedup_vs_scipy_compiled_rhs']:,.0f}x scipy + compiled RHS, {out['speedup_vs_mujoco'] or float('nan'):,.1f}x MuJoCo + Python aero"
        )
    if args.json:
        print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
