"""Free-flight emulation (the rig's purpose): the model's heave-pitch response to a 3-2-1-1 should match the free Hawk's.

:class:`FreeHawkShortPeriod` is the reference: the linear short-period and heave dynamics of the free
Hawk from its own derivatives (no rig), advanced at the control rate for all environments at once.  :class:`FreeFlightEmulation` is the task around it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from rig_env.envs.tasks.base import G0, D, Task, sign_of
from rig_env.physics import layout as L
from rig_env.signals import UNIT_3211, three_two_one_one  # noqa: F401  the one 3-2-1-1 (per-environment t0, amp); UNIT_3211 re-exported


REWARD_SCALE_FLOOR = (0.05 * D, 0.5 * D)
"""rad, rad/s: the smallest error scales of the reward (an episode whose input never begins within its time limit)."""


def expm_batch(M: np.ndarray, terms: int = 14) -> np.ndarray:
    """exp of each (k, k) matrix of M (m, k, k): scaling and squaring with a Taylor series, all at once.

    Each matrix is scaled by 2^-s so that its infinity norm is <= 1/2 (Taylor remainder below
    0.5^terms / terms!, 1e-15 for 14 terms), exponentiated, then squared s times.
    """
    norm = np.abs(M).sum(axis=2).max(axis=1)  # (m,) infinity norms
    s = np.maximum(0, np.ceil(np.log2(np.maximum(norm, 1e-300) / 0.5))).astype(np.int64)
    X = M / (2.0 ** s)[:, None, None]
    E = np.broadcast_to(np.eye(M.shape[1]), M.shape).copy()
    term = E.copy()
    for k in range(1, terms + 1):
        term = term @ X / k
        E += term
    for j in range(int(s.max(initial=0))):
        sq = j < s  # only the matrices that still need squaring
        E[sq] = E[sq] @ E[sq]
    return E


class FreeHawkShortPeriod:
    """Linear short period plus heave of the free Hawk, with its elevator servo; (n,) batch at the control rate.

    State x = (alpha, q, theta, h, delta, delta'), perturbations from trimmed level flight at the
    airspeed V (held constant: the short-period approximation, e.g. Etkin & Reid, *Dynamics of
    Flight*, longitudinal modes; Cook, *Flight Dynamics Principles*, short-period approximation).
    With qbar = rho V^2 / 2 and the Hawk's derivatives of eq. (23) (``RigParams.hawk_aero``, the same
    ones the rig's Hawk flies with: in the default file Table 4's CL and Table 3's CM terms; CMq and CLq the
    combined derivatives, split by ``alphadot_fraction`` f as the rig's aero model splits them: (1 - f) on q,
    f on alpha-dot; f = 0, the paper's model, lumps them on q), flying in the same air as the rig: a
    vertical gust w_g (m/s, world z down) adds alpha_g = -w_g / V to the angle of attack the aerodynamics
    see, alpha_a = alpha + alpha_g, while alpha, the kinematic angle between the body and the flight path,
    is what the rig's model is scored on (Etkin & Reid, response to atmospheric turbulence; the gust's
    longitudinal part changes V, which the short-period approximation holds constant):

        a_n    = (qbar S / m) (CLa alpha_a + CLq ((1 - f) q + f alpha') c / (2V) + CLde delta)   normal acceleration, up, m/s^2
        alpha' = q - a_n / V                                                        (V gamma' = a_n, gamma = theta - alpha)
        q'     = (qbar S c / Iyy) (CMa alpha_a + CMq ((1 - f) q + f alpha') c / (2V) + CMde delta)
        theta' = q,    h' = V (theta - alpha)                                       heave, up, m
        delta'' = wn^2 (u(t - d) - delta) - 2 zeta wn delta'                        the Hawk servo (rig_env.physics.servo)

    m, Iyy: Hawk mass and pitch inertia about its c.g.; u: commanded elevator (rad), held over each
    control step (as the environment holds it) and delayed by d rounded to whole control steps; alpha_g
    held over the step as the environment holds the gust.  The linear system x' = A x + B u + B_g alpha_g
    is discretised exactly for that zero-order hold (Phi = expm, per environment at reset), so a step is
    one batched matrix-vector product.  With Za = qbar S CLa / (m V), Zq = (1 - f) qbar S CLq c / (2 m V^2),
    Zad = f qbar S CLq c / (2 m V^2), Ma = qbar S c CMa / Iyy, Mq = (1 - f) qbar S c^2 CMq / (2 V Iyy) and
    Mad = f qbar S c^2 CMq / (2 V Iyy), the alpha' equation is implicit, alpha' (1 + Zad) = (1 - Zq) q - Za
    alpha_a - Zd delta, and with D = 1 + Zad the (alpha, q) characteristic equation is
    ``D s^2 + (Za - D Mq - (1 - Zq) Mad) s - Za Mq - (1 - Zq) Ma = 0`` (:meth:`short_period`; Etkin & Reid's
    short-period approximation with its Z_alphadot and M_alphadot terms).  Servo rate and position limits are not modelled (inputs of a few deg stay
    far from them).
    """

    N = 6

    def __init__(self, n: int, dt: float) -> None:
        self.n, self.dt = n, float(dt)
        self.x = np.zeros((n, self.N))
        self.an = np.zeros(n)
        self.V = np.ones(n)
        self.Za, self.Zq, self.Zd, self.Ma, self.Mq, self.Md, self.Zad, self.Mad = (np.zeros(n) for _ in range(8))
        self.wn, self.zeta, self.delay_steps = np.ones(n), np.ones(n), np.zeros(n, dtype=np.int64)
        self.Phi = np.repeat(np.eye(self.N)[None], n, axis=0)
        self.Gam = np.zeros((n, self.N))
        self.Gam_g = np.zeros((n, self.N))
        self.xg = np.zeros((n, self.N))
        self.alpha_g = np.zeros(n)

    def configure(self, idx: np.ndarray, airspeed: np.ndarray, P: np.ndarray) -> None:
        """Coefficients of envs idx from airspeed (m,) m/s and parameter rows P (m, N_PARAMS); state zeroed."""
        V = np.maximum(airspeed, 1.0)
        qbar = 0.5 * P[:, L.P_ENVIRONMENT_AIR_DENSITY] * V**2
        S, c = P[:, L.P_HAWK_AERO_S], P[:, L.P_HAWK_AERO_C]
        m, Iyy = P[:, L.P_MASS_HAWK_MASS], P[:, L.P_MASS_HAWK_IYY]
        kz, km = qbar * S / (m * V), qbar * S * c / Iyy
        self.V[idx] = V
        self.Za[idx] = kz * P[:, L.P_HAWK_AERO_CLALPHA]
        f = P[:, L.P_HAWK_AERO_ALPHADOT_FRACTION]
        self.Zq[idx] = (1.0 - f) * kz * P[:, L.P_HAWK_AERO_CLQ] * c / (2.0 * V)
        self.Zad[idx] = f * kz * P[:, L.P_HAWK_AERO_CLQ] * c / (2.0 * V)
        self.Zd[idx] = kz * P[:, L.P_HAWK_AERO_CLDE]
        self.Ma[idx] = km * P[:, L.P_HAWK_AERO_CMALPHA]
        self.Mq[idx] = (1.0 - f) * km * P[:, L.P_HAWK_AERO_CMQ] * c / (2.0 * V)
        self.Mad[idx] = f * km * P[:, L.P_HAWK_AERO_CMQ] * c / (2.0 * V)
        self.Md[idx] = km * P[:, L.P_HAWK_AERO_CMDE]
        self.wn[idx] = 2.0 * math.pi * P[:, L.P_SERVOS_HAWK_NATURAL_FREQ_HZ]
        self.zeta[idx] = P[:, L.P_SERVOS_HAWK_DAMPING]
        self.delay_steps[idx] = np.rint(P[:, L.P_SERVOS_HAWK_DELAY_S] / self.dt).astype(np.int64)
        A, B = self.matrices(idx)
        aug = np.zeros((idx.size, self.N + 2, self.N + 2))
        aug[:, : self.N, : self.N], aug[:, : self.N, self.N], aug[:, : self.N, self.N + 1] = A, B, self.gust_column(idx)
        E = expm_batch(aug * self.dt)  # zero-order-hold discretisation of both inputs
        self.Phi[idx], self.Gam[idx], self.Gam_g[idx] = E[:, : self.N, : self.N], E[:, : self.N, self.N], E[:, : self.N, self.N + 1]
        self.x[idx] = self.xg[idx] = 0.0
        self.an[idx] = 0.0
        self.alpha_g[idx] = 0.0

    def matrices(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(A (m, 6, 6), B (m, 6)) of envs idx: the equations of the class docstring."""
        m = idx.size
        V, Za, Zq, Zd = self.V[idx], self.Za[idx], self.Zq[idx], self.Zd[idx]
        wn, zeta = self.wn[idx], self.zeta[idx]
        A, B = np.zeros((m, self.N, self.N)), np.zeros((m, self.N))
        D, Mad = 1.0 + self.Zad[idx], self.Mad[idx]
        A[:, 0, 0], A[:, 0, 1], A[:, 0, 4] = -Za / D, (1.0 - Zq) / D, -Zd / D  # alpha' = q - a_n / V, solved for alpha'
        A[:, 1] = Mad[:, None] * A[:, 0]  # q' = ... + Mad alpha'
        A[:, 1, 0] += self.Ma[idx]
        A[:, 1, 1] += self.Mq[idx]
        A[:, 1, 4] += self.Md[idx]
        A[:, 2, 1] = 1.0
        A[:, 3, 0], A[:, 3, 2] = -V, V
        A[:, 4, 5] = 1.0
        A[:, 5, 4], A[:, 5, 5] = -(wn**2), -2.0 * zeta * wn
        B[:, 5] = wn**2
        return A, B

    def gust_column(self, idx: np.ndarray) -> np.ndarray:
        """(m, 6) B_g of envs idx: d x' / d alpha_g (alpha_g enters where alpha does in the loads)."""
        Bg = np.zeros((idx.size, self.N))
        D = 1.0 + self.Zad[idx]
        Bg[:, 0] = -self.Za[idx] / D
        Bg[:, 1] = self.Ma[idx] + self.Mad[idx] * Bg[:, 0]
        return Bg

    def short_period(self) -> tuple[np.ndarray, np.ndarray]:
        """(n,) natural frequency (rad/s) and damping ratio of the closed-form characteristic equation."""
        D = 1.0 + self.Zad
        wn = np.sqrt((-self.Za * self.Mq - (1.0 - self.Zq) * self.Ma) / D)
        return wn, ((self.Za - (1.0 - self.Zq) * self.Mad) / D - self.Mq) / (2.0 * wn)

    def lift_row(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n,) each: a_n / V per unit alpha_a, q and delta, alpha' eliminated: a_n / V = Za alpha_a + Zq q + Zd delta +
        Zad alpha' = (Za alpha_a + Zd delta) / D + (Zq + Zad (1 - Zq) / D) q, D = 1 + Zad."""
        D = 1.0 + self.Zad
        return self.Za / D, self.Zq + self.Zad * (1.0 - self.Zq) / D, self.Zd / D

    def normal_acceleration(self, x: np.ndarray, alpha_g: np.ndarray | float = 0.0) -> np.ndarray:
        """(n,) a_n, m/s^2, of states x (n, 6) in a gust of alpha_g (n,) rad."""
        ka, kq, kd = self.lift_row()
        return self.V * (ka * (x[:, 0] + alpha_g) + kq * x[:, 1] + kd * x[:, 4])

    def step(self, u: np.ndarray, alpha_g: np.ndarray | None = None) -> None:
        """Advance every env one control step with the elevator command u (n,) rad and the gust's angle of
        attack alpha_g (n,) rad (None: calm) held; updates x (the response to u), xg (to the gusts), a_n.

        The system is linear, so the two responses are kept apart (the state is x + xg): the task scores
        the whole response and normalises by the pilot input's part alone."""
        self.x = np.einsum("nij,nj->ni", self.Phi, self.x) + self.Gam * u[:, None]
        if alpha_g is not None:
            self.xg = np.einsum("nij,nj->ni", self.Phi, self.xg) + self.Gam_g * alpha_g[:, None]
        self.an = self.normal_acceleration(self.x + self.xg, 0.0 if alpha_g is None else alpha_g)


def rig_alpha(q: np.ndarray, qd: np.ndarray, V: np.ndarray, l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(alpha, pitch rate) of the model on a heave-pitch rig: (n,) rad and rad/s.

    Absolute pitch Theta = rig_pitch + model_pitch; the gimbal moves at l theta' on its arc, so the
    flight-path angle is gamma = atan2(l theta' cos theta, V - l theta' sin theta) and alpha = Theta -
    gamma (rig roll and yaw at 0; the c.g. offset from the gimbal is neglected).
    """
    th, thd = q[:, 1], qd[:, 1]
    gamma = np.arctan2(l * thd * np.cos(th), V - l * thd * np.sin(th))
    return th + q[:, 3] - gamma, thd + qd[:, 3]


class FreeFlightEmulation(Task):
    """Fly the compensator so that the model's heave-pitch response to a 3-2-1-1 matches the free Hawk's.

    Pilot input (a disturbance, :meth:`pilot_inputs`): a 3-2-1-1 on the Hawk elevator with the
    paper's 0.28 s unit period (Sec. V), amplitude U(0.5, 1.5) deg with a random sign, starting at
    t0 ~ U(1.5, 2.0) s (on the control grid).  Reference: :class:`FreeHawkShortPeriod` driven by the
    same command, giving the free Hawk's alpha_ff, q_ff and normal acceleration a_n.  The rig's model
    alpha and pitch rate follow :func:`rig_alpha` (true state); both alphas are taken from their values at
    t0 (alpha_b, the rig's, and alpha_ff_b, the free Hawk's), and the emulation error is
    e_alpha = (alpha_ff - alpha_ff_b) - (alpha - alpha_b), e_q = q_ff - q.
    The free Hawk flies in the rig's air from the episode's start: the environment's gusts (``turbulence``)
    drive the reference too (:meth:`air`; alpha_g = -w_g / V of the vertical gust), so the score asks the rig
    to respond to a gust as the free aircraft would, not to be stiffer than it.

    The free Hawk's heave after the input (a steady climb or descent once its attitude has changed)
    exceeds the rig's +-0.34 m stroke within a second, so only the aerodynamic state the model feels,
    alpha and q, is scored; the rig's heave is free to wash out (kept off the stops by the reward).

    | appended observation | meaning | normalisation |
    |---|---|---|
    | alpha_error | (alpha_ff - alpha_ff_b) - (measured alpha - alpha_b), 0 before t0 | / 5 deg, clipped to +-5 |
    | q_ref | q_ff | / 1 rad/s |
    | q_error | q_ff - estimated pitch rate | / 1 rad/s, clipped to +-5 |
    | accel_ref | a_n of the free Hawk | / 9.81 m/s^2 |
    | elevator_cmd | pilot elevator command now | / 5 deg |
    | input_active | 1 from t0, else 0 | - |

    Measured alpha uses the measured angles and rates, the episode's airspeed and the arm length.  The
    reference's alpha_ff is kinematic (body to flight path); its accel_ref includes the gust's lift.
    Reward (the form of :mod:`.base`): tracking cost from t0 ``c = (e_alpha / (0.5 s_alpha))^2 + (e_q / (0.5
    s_q))^2 + 0.5 (max(|rig pitch| - 15 deg, 0) / 5 deg)^2``; before t0 ``c = (q / 10 deg/s)^2 + (rig pitch rate /
    10 deg/s)^2`` (settle).  s_alpha and s_q are the episode's own scales, the RMS over [t0, end] of the free
    Hawk's alpha and q responses to the episode's 3-2-1-1 alone (:meth:`pilot_response_rms`, computed at reset:
    the reference is linear and its input known), as the success criterion normalises the error by the same
    signal; the error scales are the criterion's limit itself (``FIT_LIMIT`` = 0.5 of that RMS: c = 1 per term
    there), as the pull-up's angle is scored on its settling band.  Fixed scales (1.5 deg, 15 deg/s) weighed the
    same relative error differently by the input's amplitude and airspeed (the response's RMS is 1.0-2.5 deg and
    6-19 deg/s over the 0.5-1.5 deg inputs and 15-25 m/s).  The command-activity weight is 0.02
    (``rate_weight``), a tenth of the other tasks': the emulation needs a fast flap (the model-following LQR
    commands 245 deg/s RMS against the 3-2-1-1's 0.28 s steps), and at the shared 0.2 the rate cost outweighed
    the emulation's last part: along a = k a_LQR (the LQR's gains scaled; ``scripts/reward_along_lqr.py``, 64
    nominal episodes seeded 30000) the return peaked at k = 0.5 (297 of 480; k = 1: 263, median emulation error
    0.52 and 0.46), so the reward's optimum was a weaker emulation than the criterion asks.  With both changes
    it peaked at k = 1 (252; k = 0.5: 242, 0.75: 251, 1.25: 248) and chatter still costs: a +-0.05 square wave
    at 5 Hz on top of the LQR's command 252 -> 247, +-0.1 at 2.5 Hz 242, +-0.2 at 10 Hz 178 (the deflection
    cost and the lower rate term together; all measured with the LQR before its gust estimate and the
    reference's gusts from the start).  With them, the return is flat across k = 0.75-1 (320 and 317; k = 0.5:
    307, 1.25: 309; success 98 % and 100 %).  PPO from scratch does not learn the task; fine-tuned from a clone
    of the model-following LQR (``rig train --warm-start lqr``) it flies 95 % of the comparison's nominal
    episodes (benchmarks/RESULTS.md, RL training).
    Metrics: RMS error is e_alpha in deg (0 before t0); no step segments (rise, settling, overshoot NaN); ``emulation_error`` = sqrt(sum
    e_alpha^2 / sum alpha_ff^2) over [t0, end].  Success: reached the time limit with emulation_error
    below 0.5.
    Defaults: free rig_pitch and model_pitch (both required), airspeed U(18, 22) m/s, 6 s.  Initial
    state: rig pitch U(6, 8) deg, model pitch +- 1 deg, at rest.
    The limit is within reach: without control the normalised error is about 1.5 (the rig's lightly
    damped heave-pitch mode rings); a static law on the six task entries and the rig-pitch rate
    (hand-searched gains, with feedforward of accel_ref) reached a median of 0.31 over 32 episodes, and
    the model-following LQR (:mod:`controllers.laws.emulation`) reaches it in every one of 32 episodes in calm
    air (median 0.30, 15-25 m/s, sensor noise, servo spread).  Before the reference flew in the rig's air,
    turbulence was scored as error (the rig's response to 1 % gusts alone was 0.40 of the signal with the
    LQR, 0.62 open loop) and the LQR met the criterion in 44 % of the comparison's nominal episodes.

    The criterion in gusts: a rig that flew as the free Hawk (the same response to the pilot's input and to
    the gust, from the episode's start) scores 0; the normaliser is the pilot input's response alone, so a
    gust response the rig gets wrong counts against it.  Until the reference met the gusts from the
    episode's start it met them from t0 only, starting at rest while the rig arrived at t0 with its own
    response to the gusts before it: that criterion failed a perfect emulator (the free Hawk itself, flown
    in the same gusts from the start) in 18 % of 4000 episodes of the comparison's nominal draws (1 %
    Gauss-Markov gusts, 15-25 m/s; median error 0.24), and the model-following LQR passed 77 % of the
    comparison's 64 nominal episodes.  With gusts from t0 only (calm before it) the same LQR passed all 64
    (median 0.31): its failures were that initial state, not its emulation.  Normalising by the whole
    reference (pilot and gust) instead would still fail the perfect emulator whenever its pre-t0 state
    differs, so the normaliser stays.
    """

    name = "free_flight_emulation"
    display_label = "model alpha from its baseline, deg"
    default_free_dofs = ("rig_pitch", "model_pitch")
    default_airspeed = (18.0, 22.0)
    default_episode_seconds = 6.0
    required = ("rig_pitch", "model_pitch")
    ref_labels = ("alpha_error", "q_ref", "q_error", "accel_ref", "elevator_cmd", "input_active")
    ref_scales = {"alpha_error": 5.0 * D, "q_ref": 1.0, "q_error": 1.0, "accel_ref": G0, "elevator_cmd": 5.0 * D, "input_active": 1.0}
    """Units (rad, rad/s, m/s^2, -) per normalised value of the appended entries (the table above); the observation
    divides by them."""
    n_draws = 3 + 5
    FIT_LIMIT = 0.5
    """The criterion's limit on ``emulation_error``; the reward's error scales are this share of the response's RMS."""
    rate_weight = 0.02
    """The control cost's command-activity weight, a tenth of the other tasks' (class docstring, Reward)."""

    @classmethod
    def driven_joint(cls, options: Mapping[str, Any]) -> str:
        """rig_pitch: the rig emulates the free Hawk's heave with it."""
        return "rig_pitch"

    def __init__(self, n_envs: int, free_dofs: tuple[str, ...], dt: float, episode_seconds: float) -> None:
        super().__init__(n_envs, free_dofs, dt, episode_seconds)
        self.model = FreeHawkShortPeriod(n_envs, dt)
        z = np.zeros(n_envs)
        self.t0, self.amp, self.alpha_b, self.alpha_ff_b = z.copy(), z.copy(), z.copy(), z.copy()
        self.e2, self.r2 = z.copy(), z.copy()
        self.s_alpha, self.s_q = np.full(n_envs, REWARD_SCALE_FLOOR[0]), np.full(n_envs, REWARD_SCALE_FLOOR[1])
        self.cp, self.cm = self.col("rig_pitch"), self.col("model_pitch")
        self._pilot = np.zeros((n_envs, 3))

    def conditions(self, idx: np.ndarray, airspeed: np.ndarray, P: np.ndarray) -> None:
        """Also builds the free-Hawk reference model of envs idx from their airspeed and parameters."""
        super().conditions(idx, airspeed, P)
        self.model.configure(idx, airspeed, P)

    def reset(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.t0[idx] = np.round((1.5 + 0.5 * u[:, 0]) / self.dt) * self.dt
        self.amp[idx] = sign_of(u[:, 1]) * (0.5 + 1.0 * u[:, 2]) * D
        self.alpha_b[idx] = self.alpha_ff_b[idx] = self.e2[idx] = self.r2[idx] = 0.0
        self.s_alpha[idx], self.s_q[idx] = self.pilot_response_rms(idx)
        q0, qd0 = self.initial_state(idx, u[:, 3:])
        q0[:, 1] = (7.0 + q0[:, 1] / (3.0 * D)) * D
        q0[:, 3] = q0[:, 3] / 3.0
        return q0, qd0

    def pilot_response_rms(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """((m,), (m,)): RMS over [t0, end] of the free Hawk's alpha (rad) and q (rad/s) responses to this episode's
        3-2-1-1 alone (no gusts) in envs idx: the criterion's normaliser, known at reset (the reference model is
        linear and its input fixed), advanced exactly as :meth:`advance` advances it; floored at
        :data:`REWARD_SCALE_FLOOR`."""
        m = self.model
        Phi, Gam, d = m.Phi[idx], m.Gam[idx], m.delay_steps[idx]
        t0, amp = self.t0[idx], self.amp[idx]
        x = np.zeros((idx.size, m.N))
        sa, sq, k = np.zeros(idx.size), np.zeros(idx.size), np.zeros(idx.size)
        for j in range(1, int(round(self.T / self.dt)) + 1):
            t = j * self.dt
            x = np.einsum("nij,nj->ni", Phi, x) + Gam * three_two_one_one(np.full(idx.size, t) - self.dt * (1 + d), t0, amp)[:, None]
            on = t > t0 + 0.5 * self.dt
            sa += np.where(on, x[:, 0] ** 2, 0.0)
            sq += np.where(on, x[:, 1] ** 2, 0.0)
            k += on
        k = np.maximum(k, 1.0)
        return np.maximum(np.sqrt(sa / k), REWARD_SCALE_FLOOR[0]), np.maximum(np.sqrt(sq / k), REWARD_SCALE_FLOOR[1])

    def pilot_inputs(self, t: np.ndarray) -> np.ndarray:
        self._pilot[:, 0] = three_two_one_one(t, self.t0, self.amp)
        return self._pilot

    def air(self, gust: np.ndarray) -> None:
        """The free Hawk's gust angle of attack over the step: alpha_g = -w_g / V (world z down), from the
        episode's start, as the rig meets it (the class docstring: the criterion in gusts)."""
        self.model.alpha_g = -gust[:, 2] / self.V

    def advance(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> None:
        m = self.model
        u = three_two_one_one(t - self.dt * (1 + m.delay_steps), self.t0, self.amp)  # command held over the step, delayed
        m.step(u, m.alpha_g)
        alpha, _ = rig_alpha(q, qd, self.V, self.l)
        start = np.abs(t - self.t0) < 0.5 * self.dt
        self.alpha_b = np.where(start, alpha, self.alpha_b)
        self.alpha_ff_b = np.where(start, m.x[:, 0] + m.xg[:, 0], self.alpha_ff_b)
        on = t > self.t0 + 0.5 * self.dt
        e = m.x[:, 0] + m.xg[:, 0] - self.alpha_ff_b - (alpha - self.alpha_b)
        self.e2 += np.where(on, e**2, 0.0)
        self.r2 += np.where(on, m.x[:, 0] ** 2, 0.0)  # the pilot input's signal: the normaliser

    def reference(self, t: np.ndarray) -> np.ndarray:
        """(n, 6): alpha_ff from its value at t0 (alpha_ff_b; before t0 from the trim), q_ff, a_n, elevator command,
        active flag, alpha_b."""
        m = self.model
        active = (t > self.t0 - 0.5 * self.dt).astype(np.float64)
        return np.stack([m.x[:, 0] + m.xg[:, 0] - self.alpha_ff_b, m.x[:, 1] + m.xg[:, 1], m.an, three_two_one_one(t, self.t0, self.amp), active,
                         self.alpha_b], axis=1)

    def episode_metrics(self, idx: np.ndarray) -> dict[str, np.ndarray]:
        """``emulation_error``: sqrt(sum e_alpha^2 / sum alpha_ff^2) over [t0, end] (inf if the input never began)."""
        e2, r2 = self.e2[idx], self.r2[idx]
        return {"emulation_error": np.where(r2 > 0.0, np.sqrt(e2 / np.maximum(r2, 1e-300)), np.inf)}

    def observation(self, ref: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        th, thd = angles[:, self.cp], rates[:, self.cp]
        gamma = np.arctan2(self.l * thd * np.cos(th), self.V - self.l * thd * np.sin(th))
        alpha = th + angles[:, self.cm] - gamma
        q = thd + rates[:, self.cm]
        on = ref[:, 4] > 0.5
        sc = self.ref_scales
        obs = np.stack([
            np.where(on, ref[:, 0] - (alpha - ref[:, 5]), 0.0) / sc["alpha_error"],
            ref[:, 1] / sc["q_ref"],
            (ref[:, 1] - q) / sc["q_error"],
            ref[:, 2] / sc["accel_ref"],
            ref[:, 3] / sc["elevator_cmd"],
            ref[:, 4] / sc["input_active"],
        ], axis=1)
        return np.clip(obs, self.obs_low, self.obs_high)

    def _errors(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        alpha, qa = rig_alpha(q, qd, self.V, self.l)
        on = ref[:, 4] > 0.5
        return np.where(on, ref[:, 0] - (alpha - ref[:, 5]), 0.0), ref[:, 1] - qa, on

    def reward(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        ea, eq, on = self._errors(q, qd, ref)
        stop = np.maximum(np.abs(q[:, 1]) - 15.0 * D, 0.0) / (5.0 * D)
        tracking = (ea / (self.FIT_LIMIT * self.s_alpha)) ** 2 + (eq / (self.FIT_LIMIT * self.s_q)) ** 2 + 0.5 * stop**2
        settle = (eq / (10.0 * D)) ** 2 + (qd[:, 1] / (10.0 * D)) ** 2
        return self.shaped_reward(np.where(on, tracking, settle), a, a_prev)

    def tracked(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, ...]:
        ea, _, _ = self._errors(q, qd, ref)
        alpha, _ = rig_alpha(q, qd, self.V, self.l)
        return np.full(self.n, -1), alpha - ref[:, 5], ref[:, 0], ea / D, np.full(self.n, 0.5 * D)

    def display(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(alpha - alpha_b, alpha_ff), deg, from the input's start (NaN before: nothing is emulated yet)."""
        alpha, _ = rig_alpha(q, qd, self.V, self.l)
        on = ref[:, 4] > 0.5
        return np.where(on, (alpha - ref[:, 5]) / D, np.nan), np.where(on, ref[:, 0] / D, np.nan)

    def success(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, metrics: dict[str, np.ndarray]) -> np.ndarray:
        return metrics["emulation_error"] < self.FIT_LIMIT
