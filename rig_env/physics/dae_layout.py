"""Index layout of the DAE's state row and of its per-environment scratch row, and the solver's constants.

Coordinates q = (R_a, theta_a, R_s, theta_s, R_r) of the bodies a (aircraft), s (arm with the
compensator's inertia) and r (compensator, a point mass), Euler parameters theta = (e0, e1, e2, e3);
velocities v = (Rdot_a, omega_a, Rdot_s, omega_s, Rdot_r) with body-axis angular velocities
(:mod:`rig_env.physics.dae` gives the model).

State row Y[i] (N_DAE = 63):

    ===========  =====  ==========================================================
    Y_RA         0:3    aircraft c.g. position R_a, m (world)
    Y_QA         3:7    aircraft Euler parameters theta_a (e0, e1, e2, e3)
    Y_RS         7:10   arm c.g. position R_s, m
    Y_QS         10:14  arm Euler parameters theta_s
    Y_RR         14:17  compensator c.g. position R_r, m
    Y_VA         17:20  Rdot_a, m/s (world)
    Y_WA         20:23  omega_a, rad/s (aircraft body axes)
    Y_VS         23:26  Rdot_s, m/s
    Y_WS         26:29  omega_s, rad/s (arm body axes)
    Y_VR         29:32  Rdot_r, m/s
    Y_Z          32:37  LuGre bristle deflections, rad (JOINTS order)
    Y_SERVO      37:44  servo positions, rad (SERVOS order)
    Y_SERVO_RATE 44:51  servo rates, rad/s
    Y_TARGET     51:56  locked-joint target angles, rad (JOINTS order; used for locked joints only)
    Y_SEP        56:63  aerodynamic states: flow separation of the Hawk and flaps 1-4's panels, the wake's sidewash and
                        downwash at the compensator, m/s world (layout.X_SEP, N_AERO; F_UNSTEADY only)
    ===========  =====  ==========================================================
"""

from __future__ import annotations

import numpy as np

# ---- state row layout
Y_RA = 0
Y_QA = 3
Y_RS = 7
Y_QS = 10
Y_RR = 14
N_COORD = 17
Y_V = 17
Y_VA = 17
Y_WA = 20
Y_VS = 23
Y_WS = 26
Y_VR = 29
N_VEL = 15
Y_Z = 32
Y_SERVO = 37
Y_SERVO_RATE = 44
Y_TARGET = 51
Y_SEP = 56
N_DAE = 63

# RK state: Y[0:32] (coordinates, velocities) then Y[37:51] (servo positions and rates)
N_RK = 46
N_CMAX = 15  # 10 joint constraints + up to 5 locked joints

# ---- velocity columns (v = Rdot_a, omega_a, Rdot_s, omega_s, Rdot_r)
C_VA, C_WA, C_VS, C_WS, C_VR = 0, 3, 6, 9, 12
GROUND, ARM, AIRCRAFT = 0, 1, 2

# ---- scratch row of one environment
W_Y0 = 0
W_K = 46  # 4 stage derivatives, 4 x 46
W_YT = 230
W_UD = 276
W_J = 283  # constraint Jacobian, N_CMAX x 15, row-major
W_MJ = 508  # M^-1 J^T stored as rows (M^-1 J[r]), N_CMAX x 15
W_SCHUR = 733  # Schur complement J M^-1 J^T and its Cholesky factor (lower), N_CMAX x N_CMAX
W_C = 958  # constraint values
W_B = 973  # velocity-product terms Jdot v
W_F = 988  # applied + gyroscopic forces F (15)
W_LAM = 1003  # multipliers / projection unknowns
W_ACC = 1018  # vdot (15)
W_BACK = 1033  # last good state, N_DAE
W_ACC2 = W_BACK + N_DAE  # vdot per unit of the Hawk's alpha-dot (15)
N_WORK_DAE = W_ACC2 + 15

RK_C = (0.0, 0.5, 0.5, 1.0)
RK_W = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
PROJ_TOL = 1e-12
PROJ_ITERS = 4
PROJ_SKIP_RECHECK = 1e-10  # below this residual one Gauss-Newton update suffices


def new_work_dae(n_envs: int) -> tuple[np.ndarray]:
    """Per-environment scratch for :func:`step_batch_dae`: a 1-tuple holding (n_envs, N_WORK_DAE) floats."""
    return (np.zeros((n_envs, N_WORK_DAE)),)

