"""Every task's declared reference scales (``Task.ref_scales``) against its own observation and its docstring table.

The laws read the task entries of the observation by name and multiply them by the declared scale
(``controllers.design.signals``); these tests make that declaration unable to drift from what the
task computes: for each task, a short episode with small random actions, then every appended entry
times its declared scale equals the physical quantity rebuilt here from the task's reference and
the measured angles and rates (the class docstring's table), and the table's "normalisation"
column states the same number.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from rig_env.envs import TASKS, RigVectorEnv
from rig_env.envs.tasks.departure import ALPHA_RECOVERED, static_alpha, wrap
from rig_env.params import JOINTS

D = math.pi / 180.0
CASES = [(name, {}) for name in TASKS] + [("forced_oscillation", {"axis": "sway_yaw"})]


def _physical(env: RigVectorEnv, ref: np.ndarray, ang: np.ndarray, rate: np.ndarray, e_int: np.ndarray) -> dict[str, np.ndarray]:
    """Each appended entry's physical value (rad, rad/s, m/s^2, Hz, -) from the reference and measurements;
    e_int: the integral of the driven joint's measured error, rad s, summed here step by step."""
    task = env.task
    col = {j: k for k, j in enumerate(env.free_dofs)}
    name = env.config.task
    if name in ("velocity_vector_roll", "bank_to_bank"):
        r = col["rig_roll"]
        out = {"roll_error": ref[:, 0] - ang[:, r], "roll_ref": ref[:, 0]}
        if ref.shape[1] > 1:
            out.update(roll_rate_ref=ref[:, 1], roll_rate_error=ref[:, 1] - rate[:, r])
        return out
    if name == "pull_up_push_over":
        c = col["rig_pitch"]
        return {"heave_error": ref[:, 0] - ang[:, c], "heave_rate_ref": ref[:, 1], "heave_rate_error": ref[:, 1] - rate[:, c],
                "accel_ref": ref[:, 2], "heave_error_int": e_int}
    if name == "forced_oscillation":
        c = col[type(task).driven_joint(env.config.task_options)]
        on = ref[:, 2] > 0.0
        return {"osc_error": ref[:, 0] - ang[:, c], "osc_rate_error": ref[:, 1] - rate[:, c],
                "osc_sin": np.where(on, np.sin(ref[:, 2]), 0.0), "osc_cos": np.where(on, np.cos(ref[:, 2]), 0.0),
                "osc_amplitude": ref[:, 3], "osc_frequency": ref[:, 4]}
    if name == "free_flight_emulation":
        cp, cm = col["rig_pitch"], col["model_pitch"]
        th, thd = ang[:, cp], rate[:, cp]
        gamma = np.arctan2(task.l * thd * np.cos(th), task.V - task.l * thd * np.sin(th))
        alpha = th + ang[:, cm] - gamma
        on = ref[:, 4] > 0.5
        return {"alpha_error": np.where(on, ref[:, 0] - (alpha - ref[:, 5]), 0.0), "q_ref": ref[:, 1],
                "q_error": ref[:, 1] - (thd + rate[:, cm]), "accel_ref": ref[:, 2], "elevator_cmd": ref[:, 3], "input_active": ref[:, 4]}
    if name == "departure_recovery":
        q = np.zeros((ang.shape[0], 5))
        q[:, [JOINTS.index(j) for j in env.free_dofs]] = ang
        alpha = static_alpha(q)
        return {"alpha_est": alpha, "alpha_excess": np.maximum(np.abs(alpha) - ALPHA_RECOVERED, 0.0),
                "level_error": np.hypot(wrap(q[:, 0]), q[:, 1]), "elevator_cmd": ref[:, 0]}
    raise AssertionError(f"task {name!r}: add its entries to this test")


@pytest.mark.parametrize("task, opts", CASES)
def test_declared_scales_are_the_observations(task, opts):
    env = RigVectorEnv(6, task=task, task_options=opts)
    cls = TASKS[task]
    assert tuple(cls.ref_scales) == cls.ref_labels  # every appended entry, in order
    k0 = len(env.obs_labels) - len(cls.ref_labels)
    assert env.obs_labels[k0:] == cls.ref_labels
    rng = np.random.default_rng(1)
    env.reset(seed=3)
    steps = min(int(round(3.0 / env.dt)), int(0.9 * env.max_steps))
    checked = {label: 0 for label in cls.ref_labels}
    e_int = np.zeros(env.num_envs)  # the integral of the driven joint's measured error, rad s, held within +-5 deg s
    driven = type(env.task).driven_joint(env.config.task_options)
    for k in range(steps):
        obs, *_ = env.step(rng.uniform(-0.3, 0.3, (env.num_envs, len(env.action_names))))
        if driven is not None:
            e = env.reference()[:, 0] - env.sensors.angles[:, env.free_dofs.index(driven)]
            e_int = np.clip(e_int + env.dt * e, -5.0 * D, 5.0 * D)
        if k % 10 != 9:
            continue
        phys = _physical(env, env.reference(), env.sensors.angles, env.sensors.rates, e_int)
        for m, label in enumerate(cls.ref_labels):
            scale = cls.ref_scales[label]
            o = obs[:, k0 + m].astype(np.float64)
            inside = np.abs(o) < 4.99  # not clipped
            np.testing.assert_allclose(o[inside] * scale, phys[label][inside], rtol=1e-6, atol=1e-6 * scale, err_msg=f"{task}: {label}")
            checked[label] += int(np.count_nonzero(inside & (phys[label] != 0.0)))
    assert all(n > 0 for n in checked.values()), checked  # every entry was seen away from zero


_UNITS = {"deg": D, "rad/s": 1.0, "m/s^2": 1.0, "Hz": 1.0}


@pytest.mark.parametrize("task", list(TASKS))
def test_declared_scales_are_the_docstring_tables(task):
    """The class docstring's "appended observation" table states each declared scale ("/ 10 deg", "-" = 1)."""
    cls = TASKS[task]
    stated: dict[str, float] = {}
    for line in (cls.__doc__ or "").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not any(n in cls.ref_labels for n in (x.strip() for x in cells[0].split(","))):
            continue
        last = cells[-1]  # (a meaning may hold |x| bars: the name is the first cell, the normalisation the last)
        m = re.match(r"/\s*([\d.]+)\s*(deg|rad/s|m/s\^2|Hz)", last)
        value = float(m.group(1)) * _UNITS[m.group(2)] if m else (1.0 if last == "-" else math.nan)
        for n in (x.strip() for x in cells[0].split(",")):
            stated[n] = value
    assert set(stated) == set(cls.ref_labels), f"{task}: table names {sorted(stated)}, the task appends {list(cls.ref_labels)}"
    for label, scale in cls.ref_scales.items():
        assert stated[label] == pytest.approx(scale, rel=1e-12), f"{task}: {label}"


def test_heave_sway_tasks_name_their_driven_joint():
    assert TASKS["pull_up_push_over"].driven_joint({}) == "rig_pitch"
    assert TASKS["free_flight_emulation"].driven_joint({}) == "rig_pitch"
    assert TASKS["forced_oscillation"].driven_joint({}) == "rig_pitch"
    assert TASKS["forced_oscillation"].driven_joint({"axis": "sway_yaw"}) == "rig_yaw"
    assert TASKS["velocity_vector_roll"].driven_joint({}) is None
