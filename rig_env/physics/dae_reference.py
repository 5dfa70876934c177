"""Literal dense assembly of the paper's DAE, eq. (1) with (3)-(5), (10)-(18), in plain numpy (tests only).

Nothing here is shared with :mod:`rig_env.physics.dae` except the parameter layout: the 17x17 mass
matrix with m_thth = G^T I G blocks, the quadratic velocity vector of eq. (11), the 12 + n_locked
constraints C(q) written as in the paper (matrix entries of A(theta), polynomial in q), their
Jacobian C_q and the acceleration right-hand side Q_d = -(C_q qdot)_q qdot, and the augmented system

    [ M    C_q^T ] [ qddot  ]   [ Q_e + Q_v ]
    [ C_q  0     ] [ lambda ] = [ Q_d       ]

solved with ``numpy.linalg.solve``.  Because every constraint is a polynomial of degree <= 4 in q,
C_q and Q_d are computed with five-point difference stencils that are exact for such polynomials
(only round-off remains), independently of the analytic Jacobian of the fast kernel.

Euler parameters theta = (e0, e1, e2, e3); A(theta) the (unnormalised, polynomial) rotation matrix;
Gb = [-e, -skew(e) + e0 I]; the paper's G (omega_body = G thetadot) is 2 Gb.
"""

from __future__ import annotations

import numpy as np

from rig_env.physics import layout as L

# five-point stencils, exact for polynomials up to degree 4 (first) and 5 (second derivative)
_S1 = ((-2.0, 1.0 / 12.0), (-1.0, -8.0 / 12.0), (1.0, 8.0 / 12.0), (2.0, -1.0 / 12.0))
_S2 = ((-2.0, -1.0 / 12.0), (-1.0, 16.0 / 12.0), (0.0, -30.0 / 12.0), (1.0, 16.0 / 12.0), (2.0, -1.0 / 12.0))


def rot(th: np.ndarray) -> np.ndarray:
    """A(theta), polynomial form (equal to the rotation matrix for unit theta)."""
    e0, e1, e2, e3 = th
    return np.array(
        [
            [e0 * e0 + e1 * e1 - e2 * e2 - e3 * e3, 2 * (e1 * e2 - e0 * e3), 2 * (e1 * e3 + e0 * e2)],
            [2 * (e1 * e2 + e0 * e3), e0 * e0 - e1 * e1 + e2 * e2 - e3 * e3, 2 * (e2 * e3 - e0 * e1)],
            [2 * (e1 * e3 - e0 * e2), 2 * (e2 * e3 + e0 * e1), e0 * e0 - e1 * e1 - e2 * e2 + e3 * e3],
        ]
    )


def g_paper(th: np.ndarray) -> np.ndarray:
    """The paper's G (3x4): omega_body = G thetadot (= 2 Gb, Shabana's body-frame matrix)."""
    e0, e1, e2, e3 = th
    return 2.0 * np.array([[-e1, e0, e3, -e2], [-e2, -e3, e0, e1], [-e3, e2, -e1, e0]])


def body_inertias(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """I_a and I_s (arm + compensator, eq. 10 note) in body axes."""
    ixz = p[L.P_MASS_HAWK_IXZ]
    Ia = np.array([[p[L.P_MASS_HAWK_IXX], 0, -ixz], [0, p[L.P_MASS_HAWK_IYY], 0], [-ixz, 0, p[L.P_MASS_HAWK_IZZ]]])
    Is = np.diag(
        [
            p[L.P_MASS_ARM_IXX] + p[L.P_MASS_COMP_IXX],
            p[L.P_MASS_ARM_IYY] + p[L.P_MASS_COMP_IYY],
            p[L.P_MASS_ARM_IZZ] + p[L.P_MASS_COMP_IZZ],
        ]
    )
    return Ia, Is


def constraints(q: np.ndarray, p: np.ndarray, locked: list[int], targets: np.ndarray) -> np.ndarray:
    """C(q): eqs. (13)-(18) and one row per locked joint, as polynomials in the 17 coordinates."""
    Ra, tha, Rs, ths, Rr = q[0:3], q[3:7], q[7:10], q[10:14], q[14:17]
    Aa, As = rot(tha), rot(ths)
    lf = np.array([p[L.P_GEOMETRY_ARM_LENGTH], 0.0, 0.0])
    lcga = np.array([p[L.P_GEOMETRY_HAWK_CG_X], 0.0, p[L.P_GEOMETRY_HAWK_CG_Z]])
    lcgs = np.array([p[L.P_GEOMETRY_ARM_CG_X], p[L.P_GEOMETRY_ARM_CG_Y], p[L.P_GEOMETRY_ARM_CG_Z]])
    lr = np.array([p[L.P_GEOMETRY_COMP_CG_X], p[L.P_GEOMETRY_COMP_CG_Y], p[L.P_GEOMETRY_COMP_CG_Z]])
    rel = As.T @ Aa
    rows = [
        [tha @ tha - 1.0],  # (13)
        [ths @ ths - 1.0],  # (14)
        Ra - As @ lf - Aa @ lcga,  # (15)
        Rs - As @ lcgs,  # (16)
        Rr - As @ lr,  # (17)
        [rel[2, 1]],  # (18)
    ]
    for j in locked:
        t = targets[j]
        c, s = np.cos(t), np.sin(t)
        if j == L.J_RIG_ROLL:  # tan(phi) = As[2,1] / As[2,2]
            rows.append([c * As[2, 1] - s * As[2, 2]])
        elif j == L.J_RIG_PITCH:  # sin(theta) = -As[2,0]
            rows.append([As[2, 0] + s])
        elif j == L.J_RIG_YAW:  # tan(psi) = As[1,0] / As[0,0]
            rows.append([c * As[1, 0] - s * As[0, 0]])
        elif j == L.J_MODEL_PITCH:  # rel = Rz(psi_a) Ry(theta_a): rel[2,0] = -sin(theta_a)
            rows.append([rel[2, 0] + s])
        else:  # rel[0,1] = -sin(psi_a), rel[1,1] = cos(psi_a)
            rows.append([c * rel[0, 1] + s * rel[1, 1]])
    return np.concatenate([np.asarray(r, dtype=float) for r in rows])


def constraint_jacobian(q, p, locked, targets, delta: float = 0.5) -> np.ndarray:
    """C_q (12 + n_locked, 17), exact up to round-off (C is a polynomial of degree <= 4)."""
    cols = []
    for k in range(17):
        e = np.zeros(17)
        e[k] = delta
        cols.append(sum(w * constraints(q + s * e, p, locked, targets) for s, w in _S1) / delta)
    return np.stack(cols, axis=1)


def acceleration_rhs(q, qd, p, locked, targets) -> np.ndarray:
    """Q_d = -(C_q qdot)_q qdot = -d^2/ds^2 C(q + s qdot) at s = 0 (exact up to round-off)."""
    delta = 0.5 / max(1.0, float(np.max(np.abs(qd))))
    d2 = sum(w * constraints(q + s * delta * qd, p, locked, targets) for s, w in _S2) / delta**2
    return -d2


def paper_accelerations(
    q: np.ndarray,
    qd: np.ndarray,
    loads: np.ndarray,
    p: np.ndarray,
    locked: list[int],
    targets: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Solve the dense augmented system of eq. (1) for (qddot (17), lambda (12 + n_locked)).

    q, qd: (R_a, theta_a, R_s, theta_s, R_r) and its time derivative; loads (15): applied forces at
    the c.g.s and moments, world axes, (f_a, n_a, f_s, n_s, f_r) (gravity included); p: parameter
    vector; locked: locked joint indices; targets (5): their angles.
    """
    ma, ms, mr = p[L.P_MASS_HAWK_MASS], p[L.P_MASS_ARM_MASS], p[L.P_MASS_COMP_MASS]
    Ia, Is = body_inertias(p)
    tha, ths = q[3:7], q[10:14]
    tha_d, ths_d = qd[3:7], qd[10:14]
    Ga, Gs = g_paper(tha), g_paper(ths)
    Ga_d, Gs_d = g_paper(tha_d), g_paper(ths_d)  # G is linear in theta
    wa, ws = Ga @ tha_d, Gs @ ths_d  # eq. (8)
    M = np.zeros((17, 17))  # eqs. (3)-(5), (10)
    M[0:3, 0:3] = ma * np.eye(3)
    M[3:7, 3:7] = Ga.T @ Ia @ Ga
    M[7:10, 7:10] = ms * np.eye(3)
    M[10:14, 10:14] = Gs.T @ Is @ Gs
    M[14:17, 14:17] = mr * np.eye(3)
    Qv = np.zeros(17)  # eq. (11) in the form -2 Gdot^T I omega
    Qv[3:7] = -2.0 * Ga_d.T @ Ia @ wa
    Qv[10:14] = -2.0 * Gs_d.T @ Is @ ws
    Aa, As = rot(tha), rot(ths)
    Qe = np.zeros(17)  # eq. (12): forces on R, body-frame moments through G^T
    Qe[0:3] = loads[0:3]
    Qe[3:7] = Ga.T @ (Aa.T @ loads[3:6])
    Qe[7:10] = loads[6:9]
    Qe[10:14] = Gs.T @ (As.T @ loads[9:12])
    Qe[14:17] = loads[12:15]
    Cq = constraint_jacobian(q, p, locked, targets)
    Qd = acceleration_rhs(q, qd, p, locked, targets)
    m = Cq.shape[0]
    K = np.zeros((17 + m, 17 + m))
    K[:17, :17] = M
    K[:17, 17:] = Cq.T
    K[17:, :17] = Cq
    sol = np.linalg.solve(K, np.concatenate([Qe + Qv, Qd]))
    return sol[:17], sol[17:]


def body_accelerations(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """(Rddot_a, omegadot_a, Rddot_s, omegadot_s, Rddot_r) (15) from qddot: omegadot = G thetaddot + Gdot thetadot."""
    out = np.empty(15)
    out[0:3] = qdd[0:3]
    out[3:6] = g_paper(q[3:7]) @ qdd[3:7] + g_paper(qd[3:7]) @ qd[3:7]
    out[6:9] = qdd[7:10]
    out[9:12] = g_paper(q[10:14]) @ qdd[10:14] + g_paper(qd[10:14]) @ qd[10:14]
    out[12:15] = qdd[14:17]
    return out


def coordinates_from_dae_state(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(q (17), qdot (17)) of a DAE state row: thetadot = G^T omega / 4 (= Gb^T omega / 2)."""
    q = np.array(y[0:17], dtype=float)
    qd = np.empty(17)
    qd[0:3] = y[17:20]
    qd[3:7] = g_paper(q[3:7]).T @ y[20:23] / 4.0
    qd[7:10] = y[23:26]
    qd[10:14] = g_paper(q[10:14]).T @ y[26:29] / 4.0
    qd[14:17] = y[29:32]
    return q, qd
