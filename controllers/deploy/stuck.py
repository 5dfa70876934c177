"""``StuckDetector``: the loop's stuck-sensor watchdog (a free joint's reading frozen while the rig is driven).

A real joint converter (potentiometer through an ADC, magnetic encoder) is quantised and noisy, so the
reading of a joint that moves, and of a still one read through a noisy converter, changes from frame to
frame; a stuck channel (broken wiper or cable, frozen ADC, hung converter firmware, the sim rig's
``--stuck``) repeats one value.  A repeated value alone is not a fault: a still joint read by a
noise-free converter (an encoder at rest) repeats it forever.  The rule therefore asks for two things,
per free joint ``j``, on fresh frames only (a bridged or duplicated frame is never counted):

| condition | meaning |
|---|---|
| frozen | the reading of ``j`` equals (bit for bit, as transmitted: float32) the value it had ``frames`` frames earlier, and every frame between |
| driven | over those same frames, some commanded surface moved by at least ``cmd_span (U_REF / U)^2`` rad (max - min of the command the loop sent; U the frame's airspeed, m/s) |

Both hold: the joint is reported (the loop latches FAULT ``stuck_sensor``, naming it).

Why "driven" and not "the joint's rate was non-zero when it froze": with quantisation the rate estimate
at a joint's last change is about ``lsb / dt`` (7 deg/s for a 12-bit pot at 80 Hz) even for a joint
creeping to rest, and a joint that decelerates or reaches a stop keeps a lagged non-zero estimate, so
that evidence false-trips on every joint that comes to rest under a noise-free converter.  A command
change is evidence the rig cannot ignore: at 18 m/s (the bottom of velocity_vector_roll's airspeed
range) one degree of compensator aileron gives 1.16 rad/s^2 of rig-roll acceleration
(``rig_env.linear.linearize`` at rest), while the rig roll's breakaway friction (0.0596 N m in the
model; 0.058-0.061 measured, docs/PARAMETERS.md) on its inertia of at least 0.14 kg m^2 (without the model) gives
at most 0.43 rad/s^2, so friction can hold the rig still through a command change of at most
2 x 0.43 / 1.16 = 0.73 deg; the default ``cmd_span`` of 2 deg is 2.7 times that.  The aerodynamic moment
of a deflection grows as U^2 delta (the linear model's B: 66.5 rad/s^2/rad at 18 m/s, 29.6 at 12 m/s),
so at airspeed U the span asked for is ``cmd_span (U_REF / U)^2`` (U_REF = 18 m/s): the same margin over
friction at every airspeed (``tests/test_deploy_stuck.py`` checks it at 18 and 12 m/s); with the wind
off (U = 0) nothing is evidence and the watchdog is quiet.  A rig sitting still under a constant command (DISARMED, FAULT at
neutral, a law holding its output) has no evidence and never trips.

Not detected: a channel frozen while the command stays within that span (a law holding a steady
output: indistinguishable from a rig at rest; the wind off); a fault that freezes the angle but keeps adding noise
downstream (not bit-identical); a wrong but moving reading (offset, gain, a slipping coupling).  Can
false-trip: a free joint held still (at a mechanical stop, or by the motion of the others) while the
command moves and its converter adds no noise; with the default rig's 0.05 deg noise that reading is
not constant.
"""

from __future__ import annotations

import numpy as np

U_REF = 18.0  # m/s: the airspeed at which ``cmd_span`` is the evidence (bottom of velocity_vector_roll's range)


class StuckDetector:
    """Per-joint frozen-reading counters with the command span over each run (module table).

    joints: names of the monitored (free) joints.  frames: repeats needed (None or 0: disabled).
    cmd_span: rad, the command movement that counts as "driven" at ``U_REF`` (0: any frozen run trips).
    ``update(angles, command, airspeed)``: angles (n_j,) rad of a fresh frame, command (n_s,) rad (the
    last command sent), airspeed m/s (the frame's); returns the index of the first stuck joint, or -1.  ``run`` (n_j,) repeats so far,
    ``span`` (n_j,) rad the command's movement over each joint's current run.
    """

    def __init__(self, joints: tuple[str, ...], frames: int | None, cmd_span: float, n_surfaces: int) -> None:
        n = len(joints)
        self.joints, self.frames, self.cmd_span = tuple(joints), int(frames or 0), float(cmd_span)
        self.value = np.full(n, np.nan)  # NaN never equals: the first frame starts every run
        self.run = np.zeros(n, dtype=np.int64)
        self.cmin, self.cmax = np.zeros((n, n_surfaces)), np.zeros((n, n_surfaces))
        self.span = np.zeros(n)

    def reset(self) -> None:
        """Forget every run (the next frame starts them afresh)."""
        self.value[:] = np.nan
        self.run[:] = 0

    def update(self, angles: np.ndarray, command: np.ndarray, airspeed: float) -> int:
        if not self.frames:
            return -1
        same = angles == self.value
        new = ~same
        self.run[same] += 1
        self.run[new] = 0
        self.value[new] = angles[new]
        self.cmin[new] = command
        self.cmax[new] = command
        np.minimum(self.cmin, command, out=self.cmin)
        np.maximum(self.cmax, command, out=self.cmax)
        np.max(self.cmax - self.cmin, axis=1, out=self.span)
        # span >= cmd_span (U_REF / U)^2 without dividing by U (U = 0: no evidence unless cmd_span = 0)
        hit = (self.run >= self.frames) & (self.span * airspeed**2 >= self.cmd_span * U_REF**2)
        return int(np.argmax(hit)) if hit.any() else -1
