"""MJCF export of the rig mechanism, an independent MuJoCo model of the joint-space equations.

The same three bodies and five hinges as :mod:`rig_env.physics.joint_space` (paper Sec. II), written
as a MuJoCo kinematic tree.  World axes x upstream, y starboard, z down, origin at the pivot; gravity
``(0, 0, +g)``.  The chain, outermost first (MuJoCo joint order)::

    rig_yaw (world z) -> rig_pitch (y) -> rig_roll (x): arm        A_s = Rz(psi) Ry(theta) Rx(phi)
        compensator: welded to the arm, mass comp_mass at comp_cg, inertia comp_I (arm axes)
        model_yaw (arm z, at [arm_length, 0, 0]) -> model_pitch (y): hawk     A_a = A_s Rz(psi_a) Ry(theta_a)

MuJoCo refuses a massless body that moves on a joint and carries another jointed body (``mass and
inertia of moving bodies must be larger than mjMINVAL``), so there are no massless gimbal rings: the
three rig joints are hinges of the arm body and the two model joints hinges of the hawk body (MuJoCo
composes the joints of one body in order, A = R_1(q_1) R_2(q_2) ...).  A locked joint is a fixed
rotation folded into the axes of the hinges further out (see :func:`_gimbal`), so any subset of
joints may be free, including a locked joint between two free ones; no mass is added anywhere.

Only the mechanism is modelled: no aerodynamics, friction, stops, damping or contacts (the geoms are
visual only).  A wind-off test fixture on a free joint (``fixture.<joint>.*``) becomes the hinge's
``armature`` (its inertia, added to the joint's diagonal of MuJoCo's mass matrix as rig_env adds it) and
its ``stiffness`` and ``springref`` (the spring); a fixture's constant ``torque`` has no MJCF attribute
and is refused.  The locked angles are stored in the model as custom numerics
``locked_<joint>``, so the state helpers below need only the model.

MuJoCo orders its joints along the chain (:data:`CHAIN`), not in :data:`rig_env.JOINTS` order; the
helpers map joint-space vectors ``(..., 5)`` in JOINTS order to ``qpos``/``qvel`` by joint name.

:func:`to_mjcf` needs only numpy; the other functions need the optional ``mujoco`` package.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from rig_env.params import JOINTS, RigParams

if TYPE_CHECKING:  # mujoco is an optional dependency (extra "test"); to_mjcf needs only numpy
    import mujoco

CHAIN: tuple[str, ...] = ("rig_yaw", "rig_pitch", "rig_roll", "model_yaw", "model_pitch")
"""The joints in kinematic order, outermost first: the order of MuJoCo's joints and dofs."""

AXES: dict[str, tuple[float, float, float]] = {
    "rig_yaw": (0.0, 0.0, 1.0),
    "rig_pitch": (0.0, 1.0, 0.0),
    "rig_roll": (1.0, 0.0, 0.0),
    "model_yaw": (0.0, 0.0, 1.0),
    "model_pitch": (0.0, 1.0, 0.0),
}
"""Hinge axis of each joint in the frame of the gimbal ring it turns (A_s = Rz Ry Rx, A_a = A_s Rz Ry)."""

ARM_JOINTS: tuple[str, ...] = CHAIN[:3]
HAWK_JOINTS: tuple[str, ...] = CHAIN[3:]
LOCKED_PREFIX = "locked_"


def _num(x: float) -> str:
    """Shortest repr that round-trips the float exactly."""
    return repr(float(x))


def _vec(*xs: float) -> str:
    return " ".join(_num(x) for x in xs)


def _rot(axis: tuple[float, float, float], angle: float) -> np.ndarray:
    """3x3 rotation by ``angle`` (rad) about the unit coordinate ``axis``."""
    k = int(np.argmax(np.abs(axis)))
    c, s = math.cos(angle), math.sin(angle)
    i, j = (k + 1) % 3, (k + 2) % 3
    R = np.eye(3)
    R[i, i] = c
    R[j, j] = c
    R[j, i] = s
    R[i, j] = -s
    return R


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a b of quaternions (w, x, y, z): the rotation a after b in the body frame."""
    return np.array(
        [
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        ]
    )


def _check_joints(free_dofs: Iterable[str], locked: Mapping[str, float] | None) -> tuple[tuple[str, ...], dict[str, float]]:
    """Validated free joints (as given) and the angle (rad) of every locked joint."""
    if isinstance(free_dofs, str):
        raise ValueError(f"free_dofs: expected a sequence of joint names, got the string {free_dofs!r}")
    free = tuple(free_dofs)
    for name in free:
        if name not in JOINTS:
            raise ValueError(f"free_dofs: unknown joint {name!r}; valid joints: {', '.join(JOINTS)}")
    if len(set(free)) != len(free):
        raise ValueError(f"free_dofs: duplicate joint names in {free}")
    if not free:
        raise ValueError("free_dofs: all five joints are locked; at least one joint must be free")
    if locked is not None and not isinstance(locked, Mapping):
        raise ValueError(f"locked: expected a mapping of joint name to angle (rad), got {type(locked).__name__}")
    angles = {j: 0.0 for j in JOINTS if j not in free}
    for name, value in (locked or {}).items():
        if name not in JOINTS:
            raise ValueError(f"locked: unknown joint {name!r}; valid joints: {', '.join(JOINTS)}")
        if name in free:
            raise ValueError(f"locked: joint {name!r} is also in free_dofs")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"locked: angle of {name!r} must be a number (rad), got {value!r}") from None
        if not math.isfinite(v):
            raise ValueError(f"locked: angle of {name!r} must be finite, got {value!r}")
        angles[name] = v
    return free, angles


def _gimbal(
    joints: tuple[str, ...], free: tuple[str, ...], angles: dict[str, float], indent: str, extra: Mapping[str, str]
) -> tuple[str, np.ndarray, np.ndarray]:
    """Hinge elements of one gimbal (all in the body it turns) and its trailing fixed rotation F (matrix, quat).

    The gimbal turns the body by R_1(q_1) R_2(q_2) ... (outermost first).  A locked joint is a fixed
    rotation C; moving it past a later hinge, C R_b(q) = R_{C b}(q) C, turns that hinge's axis.  So
    the body gets the free hinges with axes F_k b_k (F_k: product of the locked rotations before joint
    k) in order, and the body frame X is A F^T: a vector r in gimbal axes has body coordinates F r.
    extra: further attributes of each free joint's element (the fixture's), by joint name.
    """
    F = np.eye(3)
    qF = np.array([1.0, 0.0, 0.0, 0.0])
    lines = []
    for j in joints:
        if j in free:
            lines.append(f'{indent}<joint name="{j}" type="hinge" axis="{_vec(*(F @ np.array(AXES[j])))}"{extra.get(j, "")}/>')
        else:
            F = F @ _rot(AXES[j], angles[j])
            h = 0.5 * angles[j]
            qF = _quat_mul(qF, np.array([math.cos(h), *(math.sin(h) * a for a in AXES[j])]))
            lines.append(f"{indent}<!-- {j} locked at {_num(angles[j])} rad -->")
    return "\n".join(lines), F, qF


def to_mjcf(
    params: RigParams,
    free_dofs: Iterable[str] = JOINTS,
    locked: Mapping[str, float] | None = None,
    timestep: float = 0.0025,
) -> str:
    """MJCF XML of the rig mechanism with ``free_dofs`` as hinges and the other joints locked.

    params: rig parameters (geometry, mass properties, gravity); free_dofs: names from
    :data:`rig_env.JOINTS`, any order (MuJoCo orders them along :data:`CHAIN`); locked: angle (rad)
    of locked joints, default 0; timestep: MuJoCo physics step (s), integrator RK4.
    Raises ValueError naming ``params``, ``free_dofs``, ``locked`` or ``timestep`` on bad input.
    """
    if not isinstance(params, RigParams):
        raise ValueError(f"params: expected RigParams, got {type(params).__name__}")
    free, angles = _check_joints(free_dofs, locked)
    dt = float(timestep)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"timestep: must be a positive finite number of seconds, got {timestep!r}")
    g, m = params.geometry, params.mass
    extra = {}
    for j in free:
        fx = getattr(params.fixture, j)
        if fx.torque != 0.0:
            raise ValueError(f"params: fixture.{j}.torque = {fx.torque} N m has no MJCF equivalent (a constant joint force)")
        if (fx.stiffness, fx.inertia) != (0.0, 0.0):
            extra[j] = f' armature="{_num(fx.inertia)}" stiffness="{_num(fx.stiffness)}" springref="{_num(fx.neutral)}"'
    arm_joints, Fs, q_s = _gimbal(ARM_JOINTS, free, angles, " " * 6, extra)
    hawk_joints, Fa, q_a = _gimbal(HAWK_JOINTS, free, angles, " " * 8, extra)
    # the arm body frame X satisfies A_s = X Fs: a vector r in arm axes has body coordinates Fs r
    arm_cg = Fs @ np.array([g.arm_cg_x, g.arm_cg_y, g.arm_cg_z])
    comp_cg = Fs @ np.array([g.comp_cg_x, g.comp_cg_y, g.comp_cg_z])
    gimbal = Fs @ np.array([g.arm_length, 0.0, 0.0])
    # hawk: c.g. and inertia (Ixz as the product of inertia, I = [[Ixx, 0, -Ixz], ...]) in its body frame
    hawk_cg = Fa @ np.array([g.hawk_cg_x, 0.0, g.hawk_cg_z])
    I_a = np.array([[m.hawk_Ixx, 0.0, -m.hawk_Ixz], [0.0, m.hawk_Iyy, 0.0], [-m.hawk_Ixz, 0.0, m.hawk_Izz]])
    I_a = Fa @ I_a @ Fa.T
    full = (I_a[0, 0], I_a[1, 1], I_a[2, 2], I_a[0, 1], I_a[0, 2], I_a[1, 2])
    custom = "\n".join(f'    <numeric name="{LOCKED_PREFIX}{j}" data="{_num(a)}"/>' for j, a in angles.items())
    custom_block = f"  <custom>\n{custom}\n  </custom>\n" if custom else ""
    L = g.arm_length
    r_tube = max(g.arm_radius, 0.005)
    return f"""<mujoco model="manoeuvre_rig">
  <!-- rig_env.mjcf: mechanism only (no aero, friction, stops); x upstream, y starboard, z down -->
  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>
  <option timestep="{_num(dt)}" integrator="RK4" gravity="0 0 {_num(params.environment.gravity)}">
    <flag contact="disable"/>
  </option>
{custom_block}  <default>
    <joint armature="0" damping="0" frictionloss="0" stiffness="0" limited="false"/>
    <geom contype="0" conaffinity="0" rgba="0.6 0.6 0.7 1"/>
  </default>
  <worldbody>
    <body name="arm" pos="0 0 0">
{arm_joints}
      <inertial pos="{_vec(*arm_cg)}" quat="{_vec(*q_s)}" mass="{_num(m.arm_mass)}"
                diaginertia="{_vec(m.arm_Ixx, m.arm_Iyy, m.arm_Izz)}"/>
      <frame quat="{_vec(*q_s)}">
        <geom name="arm_tube" type="capsule" fromto="{_vec(g.comp_cg_x, 0, 0, L, 0, 0)}" size="{_num(r_tube)}"/>
      </frame>
      <body name="compensator" pos="{_vec(*comp_cg)}" quat="{_vec(*q_s)}">
        <inertial pos="0 0 0" mass="{_num(m.comp_mass)}" diaginertia="{_vec(m.comp_Ixx, m.comp_Iyy, m.comp_Izz)}"/>
        <geom name="comp_panel_a" type="box" size="0.05 0.25 0.003" euler="0.7853981633974483 0 0"/>
        <geom name="comp_panel_b" type="box" size="0.05 0.25 0.003" euler="-0.7853981633974483 0 0"/>
      </body>
      <body name="hawk" pos="{_vec(*gimbal)}" quat="{_vec(*q_s)}">
{hawk_joints}
        <inertial pos="{_vec(*hawk_cg)}" mass="{_num(m.hawk_mass)}" fullinertia="{_vec(*full)}"/>
        <frame quat="{_vec(*q_a)}">
          <geom name="hawk_fuselage" type="ellipsoid" pos="{_vec(g.hawk_cg_x, 0, g.hawk_cg_z)}" size="0.3 0.04 0.04"/>
          <geom name="hawk_wing" type="box" pos="{_vec(g.hawk_cg_x, 0, g.hawk_cg_z)}" size="0.06 0.3 0.004"/>
        </frame>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def mujoco_model(
    params: RigParams,
    free_dofs: Iterable[str] = JOINTS,
    locked: Mapping[str, float] | None = None,
    timestep: float = 0.0025,
) -> mujoco.MjModel:
    """Compiled MuJoCo model of :func:`to_mjcf` (same arguments)."""
    import mujoco

    return mujoco.MjModel.from_xml_string(to_mjcf(params, free_dofs, locked, timestep))


def joint_addresses(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """(qpos address, dof address) of each joint of :data:`rig_env.JOINTS` in ``model``; -1 if locked.

    Both arrays have shape (5,), int64, JOINTS order.
    """
    import mujoco

    qadr = np.full(5, -1, dtype=np.int64)
    dadr = np.full(5, -1, dtype=np.int64)
    for k, name in enumerate(JOINTS):
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid >= 0:
            qadr[k] = model.jnt_qposadr[jid]
            dadr[k] = model.jnt_dofadr[jid]
    return qadr, dadr


def locked_angles(model: mujoco.MjModel) -> np.ndarray:
    """(5,) joint angles (rad, JOINTS order) at which ``model`` locks its non-free joints; 0 for free ones."""
    import mujoco

    out = np.zeros(5)
    for k, name in enumerate(JOINTS):
        nid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, LOCKED_PREFIX + name)
        if nid >= 0:
            out[k] = model.numeric_data[model.numeric_adr[nid]]
    return out


def to_qpos(model: mujoco.MjModel, q: np.ndarray) -> np.ndarray:
    """MuJoCo qpos (..., nq) from joint angles q (..., 5) in JOINTS order, rad; locked entries are ignored."""
    q = np.asarray(q, dtype=np.float64)
    if q.shape[-1:] != (5,):
        raise ValueError(f"q: expected shape (..., 5) in rig_env.JOINTS order, got {q.shape}")
    qadr, _ = joint_addresses(model)
    out = np.zeros(q.shape[:-1] + (model.nq,))
    free = qadr >= 0
    out[..., qadr[free]] = q[..., free]
    return out


def to_qvel(model: mujoco.MjModel, qd: np.ndarray) -> np.ndarray:
    """MuJoCo qvel (..., nv) from joint rates qd (..., 5) in JOINTS order, rad/s; locked entries are ignored."""
    qd = np.asarray(qd, dtype=np.float64)
    if qd.shape[-1:] != (5,):
        raise ValueError(f"qd: expected shape (..., 5) in rig_env.JOINTS order, got {qd.shape}")
    _, dadr = joint_addresses(model)
    out = np.zeros(qd.shape[:-1] + (model.nv,))
    free = dadr >= 0
    out[..., dadr[free]] = qd[..., free]
    return out


def from_qpos(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """Joint angles (..., 5) in JOINTS order from MuJoCo qpos (..., nq); locked joints at their locked angle."""
    qpos = np.asarray(qpos, dtype=np.float64)
    qadr, _ = joint_addresses(model)
    out = np.broadcast_to(locked_angles(model), qpos.shape[:-1] + (5,)).copy()
    free = qadr >= 0
    out[..., free] = qpos[..., qadr[free]]
    return out


def from_qvel(model: mujoco.MjModel, qvel: np.ndarray) -> np.ndarray:
    """Joint rates (..., 5) in JOINTS order from MuJoCo qvel (..., nv); zero for locked joints."""
    qvel = np.asarray(qvel, dtype=np.float64)
    _, dadr = joint_addresses(model)
    out = np.zeros(qvel.shape[:-1] + (5,))
    free = dadr >= 0
    out[..., free] = qvel[..., dadr[free]]
    return out


def set_state(model: mujoco.MjModel, data: mujoco.MjData, q: np.ndarray, qd: np.ndarray) -> None:
    """Set data.qpos/qvel from joint-space q (5,) rad and qd (5,) rad/s, and recompute kinematics."""
    import mujoco

    data.qpos[:] = to_qpos(model, q)
    data.qvel[:] = to_qvel(model, qd)
    mujoco.mj_forward(model, data)


def get_state(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """Joint-space (q, qd), each (5,) in JOINTS order, of a MuJoCo state."""
    return from_qpos(model, data.qpos), from_qvel(model, data.qvel)
