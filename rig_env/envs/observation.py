"""The one observation builder: sensor entries then the task's entries, shared by the environments and the rig loop.

``RigVectorEnv`` and the real-time loop (:mod:`controllers.deploy.loop`) both call :func:`observe`, so a
law sees identical inputs in simulation and on the rig: the measurements pass through
:class:`rig_env.envs.sensors.Sensors` (filters, rate estimation, normalisation), the task adds its
reference entries (:meth:`rig_env.envs.tasks.Task.observation`), and the result is float32 like the
environments' observation space.  :func:`task_for_seed` draws a task's reference exactly as
``RigVectorEnv.reset(seed=s)`` does for its environment 0, episode 0.
"""

from __future__ import annotations

import numpy as np

from rig_env.envs import streams as rs
from rig_env.envs.sensors import Sensors
from rig_env.envs.tasks import TASKS, Task
from rig_env.params import RigParams, param_batch
from rig_env.physics import layout as L


def observe(sensors: Sensors, task: Task, t: np.ndarray, ref: np.ndarray | None = None) -> np.ndarray:
    """(n, obs_dim) float32: ``sensors.observation()`` then ``task.observation(ref(t), angles, rates)``.

    t: (n,) time since the start of the episode (or of the armed run), s.  ref: ``task.reference(t)``
    when the caller already has it (the environment computes it once per step for the reward too).
    Each part is written straight into the float32 array (the same rounding as concatenating in
    float64 and casting).
    """
    if ref is None:
        ref = task.reference(t)
    k = sensors.obs_dim
    out = np.empty((sensors.angles.shape[0], k + len(task.ref_labels)), dtype=np.float32)
    sensors.observation(out=out[:, :k])
    out[:, k:] = task.observation(ref, sensors.angles, sensors.rates)
    return out


def labels(sensors: Sensors, task: Task) -> tuple[str, ...]:
    """Names of the entries of :func:`observe`, in order."""
    return tuple(sensors.labels()) + tuple(task.ref_labels)


def task_for_seed(
    name: str,
    free_dofs: tuple[str, ...],
    dt: float,
    episode_seconds: float,
    seed: int,
    *,
    airspeed: float = 20.0,
    arm_length: float | None = None,
    options: dict | None = None,
    params_row: np.ndarray | None = None,
) -> Task:
    """A batch-of-one task whose reference is the one ``RigVectorEnv.reset(seed=seed)`` draws (episode 0).

    name: key of ``TASKS``; free_dofs: JOINTS order; dt: control step, s; airspeed: the episode's
    tunnel speed, m/s (on the rig: the measured one at arming); arm_length: m (None: the default
    rig's); options: the task's ``task_options``; params_row: (1, N_PARAMS) kernel parameters (None: the
    default rig's, about 13 ms to load and validate: a real-time caller passes a row built once).
    Returns the task after ``conditions`` and ``reset``
    (the initial state ``reset`` also returns belongs to the rig, not to the loop, and is dropped).
    """
    if name not in TASKS:
        raise ValueError(f"task = {name!r}: unknown; valid names: {sorted(TASKS)}")
    task = TASKS[name](1, tuple(free_dofs), float(dt), float(episode_seconds), **(options or {}))
    P = param_batch(RigParams.default(), 1) if params_row is None else np.array(params_row, dtype=np.float64).reshape(1, -1)
    if arm_length is not None:
        P[:, L.P_GEOMETRY_ARM_LENGTH] = float(arm_length)
    idx = np.zeros(1, dtype=np.int64)
    task.conditions(idx, np.array([float(airspeed)]), P)
    keys = rs.env_keys(int(seed), 1)
    task.reset(idx, rs.uniform(keys, np.zeros(1, dtype=np.uint64), 0, rs.S_REFERENCE, task.n_draws))
    return task
