"""Plausibility of the rig's sensor frames: checks a frame that passed the CRC, the MAC and the seq order must also pass.

A checksum proves a frame arrived as sent, not that what was sent makes sense: a rig-side bug or a
half-initialised converter can send rig time running backwards, a joint jumping thousands of radians
in one tick, or bits this loop does not know.  :class:`Plausibility` refuses such a frame with a reason:

| reason | rule (``n`` = seq difference to the last accepted frame, ``T`` = loop period, ``dt`` = rig-time difference) |
|---|---|
| ``reserved`` | the header's reserved field is not 0 |
| ``status`` | a status bit other than :data:`controllers.deploy.protocol.STATUS_KNOWN` is set |
| ``time`` | ``|rig_time| > TIME_MAX`` (1e10 s, 317 years: any rig clock, since boot or since 1970, passes), or ``dt`` outside ``[0.25 n T, 4 n T]`` (time backwards, stalled or racing) |
| ``joint_rate`` | some joint moved by more than ``JOINT_RATE_MAX dt + JOINT_SLACK`` (50 rad/s, 0.01 rad) |

Why these bounds: the rig clock advances one period per tick and ``seq`` one per tick, so over ``n``
ticks (lost frames included) ``dt = n T`` up to clock jitter; a factor of 4 either way leaves the jitter
of any rig scheduler and still refuses a clock that stalls, runs backwards or jumps.  50 rad/s (8 rev/s) is
twice a rate of 25 rad/s that no joint of the rig should reach (no joint rate limit is published;
the sim rig's flights in tests/test_deploy_link.py stay far below it, and a limited joint cannot turn
far between its stops), and 0.01 rad (0.57 deg) covers a few converter steps of noise and
quantisation (0.05 deg noise, 0.088 deg lsb).

Policy (applied by :class:`controllers.deploy.loop.RigLoop`): an implausible frame is dropped like a
corrupt one (counted per reason; the previous accepted frame stays the reference, so a rate check after
lost frames allows the longer time), and ``implausible_frames`` consecutive implausible frames latch
FAULT ``implausible``.  The first frame, and the first after a resync (a restarted rig), have no
reference: only the reserved, status and absolute-time rules apply to them.  Numpy and the standard
library only.
"""

from __future__ import annotations

import numpy as np

from controllers.deploy import protocol as pr

TIME_MAX = 1.0e10  # s
PERIOD_RANGE = (0.25, 4.0)  # accepted rig-time step, in periods per seq step
JOINT_RATE_MAX = 50.0  # rad/s
JOINT_SLACK = 0.01  # rad
REASONS = ("reserved", "status", "time", "joint_rate")


class Plausibility:
    """Frame-to-frame checks at loop period ``period_s`` (s); :meth:`check` a frame, then :meth:`accept` it if the loop keeps it."""

    def __init__(self, period_s: float) -> None:
        if not period_s > 0.0:
            raise ValueError(f"period_s = {period_s}: must be > 0 s")
        self.period = period_s
        self.seq, self.rig_time = -1, 0.0
        self.angles = np.zeros(pr.N_JOINTS)
        self._d = np.zeros(pr.N_JOINTS)

    def reset(self) -> None:
        """Forget the reference frame (a restarted rig): the next frame is checked as a first one."""
        self.seq = -1

    def check(self, seq: int, rig_time: float, angles: np.ndarray | tuple[float, ...], status: int, reserved: int) -> str | None:
        """None if the frame is plausible, else the reason (one of :data:`REASONS`).  rig_time s; angles (5,) rad."""
        if reserved != 0:
            return "reserved"
        if status & ~pr.STATUS_KNOWN:
            return "status"
        if not abs(rig_time) <= TIME_MAX:
            return "time"
        if self.seq < 0:
            return None
        n = (seq - self.seq) & 0xFFFFFFFF
        dt = rig_time - self.rig_time
        if not PERIOD_RANGE[0] * n * self.period <= dt <= PERIOD_RANGE[1] * n * self.period:
            return "time"
        np.subtract(angles, self.angles, out=self._d)
        if np.max(np.abs(self._d)) > JOINT_RATE_MAX * dt + JOINT_SLACK:
            return "joint_rate"
        return None

    def accept(self, seq: int, rig_time: float, angles: np.ndarray | tuple[float, ...]) -> None:
        """Make this frame the reference for the next check."""
        self.seq, self.rig_time = seq, rig_time
        self.angles[:] = angles
