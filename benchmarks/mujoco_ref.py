"""MuJoCo reference throughput: what a researcher would write instead of rig_env.

Two peers for the benchmark, both on the MJCF of :mod:`rig_env.mjcf` (all five joints free, RK4 at
the physics step of 2.5 ms, one env-step = one 12.5 ms control step = 5 physics steps):

* :func:`mujoco_env_steps_per_s`: MuJoCo stepped from Python, one ``MjData`` per environment, with the
  Hawk and compensator aerodynamic loads computed each physics step by rig_env's own
  :func:`rig_env.physics.aero.hawk_aero` and :func:`rig_env.physics.aero.comp_aero` from MuJoCo's body
  poses and velocities and applied through ``qfrc_applied`` (``mj_applyFT``).  The loads are held
  over each step, including across MuJoCo's four RK4 stages (a zero-order hold: first order in the
  step, about 1e-3 rad over 5 s at 2.5 ms, see docs/MODEL.md section 7), and there is no friction, stop or servo model.
* :func:`mujoco_rollout_env_steps_per_s`: the bare mechanism (no aero) through ``mujoco.rollout`` on
  a thread pool, MuJoCo's fastest batch path.

:func:`mujoco_aero_trajectory` runs the first peer for a few environments and returns joint angles,
so the benchmark can show that the peer simulates the same thing as rig_env (flags = F_AERO).

Run ``python benchmarks/mujoco_ref.py`` for a quick table.
"""

from __future__ import annotations

import os
import time

import mujoco
import numpy as np
from mujoco import rollout

from rig_env import JOINTS, RigParams
from rig_env.mjcf import from_qpos, mujoco_model, set_state
from rig_env.physics import layout as L
from rig_env.physics.aero import comp_aero, hawk_aero

H = 0.0025  # physics step, s
N_SUB = 5  # physics steps per env-step (12.5 ms control step)
AIRSPEED = 20.0  # m/s, tunnel flow along -x


class AeroMujocoEnv:
    """One MuJoCo rig with aerodynamic loads set from Python before every physics step.

    params: rig parameters; airspeed: tunnel speed (m/s); timestep: MuJoCo step (s).  All surface
    deflections are zero.  ``step()`` advances one env-step of ``n_sub`` physics steps.
    """

    def __init__(self, params: RigParams, airspeed: float = AIRSPEED, timestep: float = H, n_sub: int = N_SUB):
        self.model = mujoco_model(params, JOINTS, None, timestep)
        self.data = mujoco.MjData(self.model)
        self.n_sub = n_sub
        self.p = params.to_vector()
        self.tab_alpha, self.tab_cl, self.tab_cm, self.tab_comp_alpha, self.tab_cn = params.tables()
        self.v_air = (-float(airspeed), 0.0, 0.0)
        self.flaps = np.zeros(L.N_SERVOS)
        self.arm = self.model.body("arm").id
        self.hawk = self.model.body("hawk").id
        self.x_ref = float(params.geometry.comp_aero_x)
        self._vel = np.zeros(6)
        self._zero = np.zeros(3)

    def reset(self, q: np.ndarray, qd: np.ndarray) -> None:
        """Joint angles q (5,) rad and rates qd (5,) rad/s in rig_env.JOINTS order."""
        mujoco.mj_resetData(self.model, self.data)
        set_state(self.model, self.data, q, qd)

    def apply_aero(self) -> None:
        """qfrc_applied from the aerodynamic loads at the current state (kinematics recomputed first)."""
        m, d = self.model, self.data
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        d.qfrc_applied[:] = 0.0
        # Hawk: body frame = aircraft axes (all joints free); velocities at its c.g., world axes
        Aa = tuple(d.xmat[self.hawk])
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, self.hawk, self._vel, 0)
        w_a = (self._vel[0], self._vel[1], self._vel[2])
        v_a = (self._vel[3], self._vel[4], self._vel[5])
        fa, ta = hawk_aero(self.p, Aa, v_a, w_a, self.v_air, 0.0, 0.0, 0.0, False, self.tab_alpha, self.tab_cl, self.tab_cm)
        mujoco.mj_applyFT(m, d, np.array(fa), np.array(ta), d.xipos[self.hawk], self.hawk, d.qfrc_applied)
        # compensator: loads at its aerodynamic reference point on the arm axis (pivot at the origin)
        As = tuple(d.xmat[self.arm])
        x = self.x_ref
        r_ref = np.array((As[0] * x, As[3] * x, As[6] * x))  # A_s [x_ref, 0, 0]
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, self.arm, self._vel, 0)
        w = (self._vel[0], self._vel[1], self._vel[2])
        r = (r_ref[0], r_ref[1], r_ref[2])
        v_ref = (w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], w[0] * r[1] - w[1] * r[0])  # w_s x r_ref
        fc, tc = comp_aero(self.p, As, v_ref, w, self.v_air, self.flaps, False, self.tab_comp_alpha, self.tab_cn)
        mujoco.mj_applyFT(m, d, np.array(fc), np.array(tc), r_ref, self.arm, d.qfrc_applied)

    def step(self) -> None:
        """One env-step: n_sub physics steps, the aerodynamic loads refreshed before each."""
        for _ in range(self.n_sub):
            self.apply_aero()
            mujoco.mj_step(self.model, self.data)

    def joint_angles(self) -> np.ndarray:
        """(5,) joint angles, rad, rig_env.JOINTS order."""
        return from_qpos(self.model, self.data.qpos)


def _initial_states(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(n, 5) angles and rates near trim: small random angles (rad) and rates (rad/s)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.2, 0.2, (n, 5))
    qd = rng.uniform(-0.5, 0.5, (n, 5))
    return q, qd


def mujoco_env_steps_per_s(params: RigParams, n_envs: int, seconds: float) -> float:
    """Env-steps/s of MuJoCo stepped from Python with aero set each physics step, ``n_envs`` envs in turn.

    One env-step = 5 physics steps of 2.5 ms.  Runs for about ``seconds`` of wall time after one
    warm-up env-step per environment (loads the numba aero kernels) and returns the steady rate.
    """
    if n_envs < 1 or not seconds > 0:
        raise ValueError(f"n_envs must be >= 1 and seconds > 0, got n_envs={n_envs}, seconds={seconds}")
    q0, qd0 = _initial_states(n_envs)
    envs = [AeroMujocoEnv(params) for _ in range(n_envs)]
    for env, q, qd in zip(envs, q0, qd0):
        env.reset(q, qd)
        env.step()
    count = 0
    t0 = time.perf_counter()
    while True:
        for env in envs:
            env.step()
        count += n_envs
        elapsed = time.perf_counter() - t0
        if elapsed >= seconds:
            return count / elapsed


def mujoco_rollout_env_steps_per_s(params: RigParams, n_envs: int, seconds: float, nthread: int | None = None) -> float:
    """Env-steps/s of the bare mechanism (no aero, friction, stops) through ``mujoco.rollout``.

    ``n_envs`` trajectories advanced in chunks of 16 env-steps (80 physics steps) on a pool of
    ``nthread`` threads (default: all CPUs); each chunk starts from the previous chunk's end state.
    """
    if n_envs < 1 or not seconds > 0:
        raise ValueError(f"n_envs must be >= 1 and seconds > 0, got n_envs={n_envs}, seconds={seconds}")
    nthread = (os.cpu_count() or 1) if nthread is None else nthread
    model = mujoco_model(params, JOINTS, None, H)
    datas = [mujoco.MjData(model) for _ in range(max(1, nthread))]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    size = mujoco.mj_stateSize(model, spec)
    state0 = np.empty((n_envs, size))
    q0, qd0 = _initial_states(n_envs)
    for i in range(n_envs):
        mujoco.mj_resetData(model, datas[0])
        set_state(model, datas[0], q0[i], qd0[i])
        mujoco.mj_getState(model, datas[0], state0[i], spec)
    chunk = 16
    out = np.empty((n_envs, chunk * N_SUB, size))
    with rollout.Rollout(nthread=nthread) as pool:
        pool.rollout(model, datas, state0, nstep=chunk * N_SUB, state=out)  # warm-up
        count = 0
        t0 = time.perf_counter()
        while True:
            state0[:] = out[:, -1]
            pool.rollout(model, datas, state0, nstep=chunk * N_SUB, state=out)
            count += n_envs * chunk
            elapsed = time.perf_counter() - t0
            if elapsed >= seconds:
                return count / elapsed


def mujoco_aero_trajectory(
    params: RigParams, q0: np.ndarray, qd0: np.ndarray, n_ctrl: int, airspeed: float = AIRSPEED, timestep: float = H
) -> np.ndarray:
    """(n_ctrl + 1, n, 5) joint angles of the aero peer from (n, 5) initial states, every 5 physics steps."""
    out = np.empty((n_ctrl + 1, q0.shape[0], 5))
    for i in range(q0.shape[0]):
        env = AeroMujocoEnv(params, airspeed, timestep, n_sub=round(N_SUB * H / timestep))
        env.reset(q0[i], qd0[i])
        out[0, i] = env.joint_angles()
        for k in range(n_ctrl):
            env.step()
            out[k + 1, i] = env.joint_angles()
    return out


if __name__ == "__main__":
    p = RigParams.default()
    print(f"machine: {os.cpu_count()} CPUs; env-step = {N_SUB} x {H * 1e3} ms")
    for n in (1, 16):
        print(f"MuJoCo + Python aero, {n:5d} envs: {mujoco_env_steps_per_s(p, n, 2.0):12,.0f} env-steps/s")
    for n in (64, 1024, 4096):
        print(f"MuJoCo rollout, mechanism, {n:5d} envs: {mujoco_rollout_env_steps_per_s(p, n, 2.0):12,.0f} env-steps/s")
