"""The overrun watchdog: tells a slow law from one operating-system preemption.

A law's ``act`` that takes longer than the budget (``overrun_s``, default half a period) once may be a
preemption of the loop's thread (measured under load: 8 ms once against a p99 of 0.2 ms); a law that is
slow takes longer again and again.  The rule: FAULT when ``act`` exceeds the budget

- on ``consecutive`` ticks in a row (default 3), or
- on more than ``window_max`` of the last ``window`` ticks the law ran (default 8 of 100).

One preemption (even one spanning two ticks) never trips; a law that is always slow trips on its
``consecutive``-th tick; a law slow on every other tick, which the first rule misses, trips on its
``window_max + 1``-th slow tick (after ``2 window_max + 1`` ticks, 17 by default).  Random preemptions
trip it only when more than 8 % of 100 ticks overrun, which is a machine unfit to fly (use
``--realtime``).  The tick that overran keeps the law's output (it is valid, only late; the deadline-miss
count records the lateness).
"""

from __future__ import annotations

import numpy as np


class OverrunWatchdog:
    """Counts the law's overruns of ``budget_s`` (s); :meth:`update` says when the rule (module docstring) trips."""

    def __init__(self, budget_s: float, consecutive: int = 3, window: int = 100, window_max: int = 8) -> None:
        if not budget_s > 0.0:
            raise ValueError(f"budget_s = {budget_s}: must be > 0 s")
        if not (isinstance(consecutive, int) and consecutive >= 1):
            raise ValueError(f"consecutive = {consecutive!r}: an integer >= 1")
        if not (isinstance(window, int) and isinstance(window_max, int) and 0 <= window_max < window):
            raise ValueError(f"window = {window!r}, window_max = {window_max!r}: need integers 0 <= window_max < window")
        self.budget, self.consecutive, self.window, self.window_max = budget_s, consecutive, window, window_max
        self._slow = np.zeros(window, dtype=bool)
        self.reset()

    def reset(self) -> None:
        """Forget the history (at arming)."""
        self._slow[:] = False
        self._i, self.in_window, self.run, self.total = 0, 0, 0, 0

    def update(self, compute_s: float) -> str | None:
        """Record one call of the law taking ``compute_s`` s; None, or why the watchdog trips."""
        slow = compute_s > self.budget
        self.in_window += int(slow) - int(self._slow[self._i])
        self._slow[self._i] = slow
        self._i = (self._i + 1) % self.window
        self.run = self.run + 1 if slow else 0
        self.total += int(slow)
        if self.run >= self.consecutive:
            return f"act over {self.budget * 1e3:.2f} ms on {self.run} consecutive ticks (last {compute_s * 1e3:.2f} ms)"
        if self.in_window > self.window_max:
            return f"act over {self.budget * 1e3:.2f} ms on {self.in_window} of the last {self.window} ticks"
        return None
