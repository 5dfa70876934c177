"""``PID``: the batched discrete PID element a rig engineer writes, with every detail stated.

One element drives one actuator channel in ``n`` environments at once (numpy, no per-environment
loop).  Per control step of length ``dt`` (explicit, s), with reference ``r``, measurement ``y``,
optional feedforward ``ff`` and optional measured derivative ``ydot``:

    e     = r - y
    d_k   = d_{k-1} + (dt / (Tf + dt)) (ydot_k - d_{k-1})            derivative ON MEASUREMENT,
            ydot_k = (y_k - y_{k-1}) / dt unless given                   first-order filter Tf (s)
    v     = kp e + I - kd d_k + ff                                      unconstrained demand
    u     = clip(v, u_prev - rate dt, u_prev + rate dt)                 rate limit (units/s; none on the first
                                                                        step after reset, u_prev = u_now after engage)
    u     = clip(u, u_min, u_max)                                       output limits
    I    += dt (ki e + (u - v) / Tt)          anti-windup "backcalc":  back-calculation, tracking time Tt
    I    += dt ki e  unless u is at a limit and ki e pushes further,    anti-windup "clamp": conditional integration
                     or u is rate limited

Bumpless engagement: :meth:`engage` sets the integrator of the masked environments so that, for the
present ``r``, ``y`` and ``ff``, the demand equals the actuator's current value ``u_now`` (the first
output after engaging is then ``u_now``: no bump), and restarts the derivative filter at ``y``.

| argument | shape | unit | meaning |
|---|---|---|---|
| kp, ki, kd | scalar or (n,) | u/y, u/(y s), u s/y | gains (``gain_scale`` in :meth:`update` multiplies all three) |
| dt | scalar | s | control period |
| tf | scalar | s | derivative filter time constant (0: unfiltered) |
| u_min, u_max | scalar | u | output limits |
| rate | scalar | u/s | output rate limit (``inf``: none) |
| antiwindup | "backcalc" or "clamp" | - | see above |
| tt | scalar | s | back-calculation tracking time (default ``sqrt(Ti Td)`` or ``Ti``, Astrom & Hagglund) |
"""

from __future__ import annotations

import math

import numpy as np


def _pos(name: str, v: float, allow_zero: bool = False, allow_inf: bool = False) -> float:
    v = float(v)
    ok = (v >= 0 if allow_zero else v > 0) and (math.isfinite(v) or (allow_inf and v == math.inf))
    if not ok:
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        raise ValueError(f"{name} = {v!r}: allowed range {rng}{' or inf' if allow_inf else ''}")
    return v


class PID:
    """Batched discrete PID with derivative on measurement, anti-windup, rate and output limits."""

    def __init__(
        self,
        n: int,
        *,
        kp: float | np.ndarray,
        ki: float | np.ndarray = 0.0,
        kd: float | np.ndarray = 0.0,
        dt: float,
        tf: float = 0.0,
        u_min: float = -1.0,
        u_max: float = 1.0,
        rate: float = math.inf,
        antiwindup: str = "backcalc",
        tt: float | None = None,
    ) -> None:
        self.n = int(n)
        self.dt = _pos("dt", dt)
        self.tf = _pos("tf", tf, allow_zero=True)
        self.rate = _pos("rate", rate, allow_inf=True)
        if not (math.isfinite(u_min) and math.isfinite(u_max) and u_min < u_max):
            raise ValueError(f"u_min, u_max = {u_min}, {u_max}: need finite u_min < u_max")
        if antiwindup not in ("backcalc", "clamp"):
            raise ValueError(f"antiwindup = {antiwindup!r}: allowed 'backcalc', 'clamp'")
        self.u_min, self.u_max, self.antiwindup = float(u_min), float(u_max), antiwindup
        self.kp, self.ki, self.kd = (np.broadcast_to(np.asarray(g, dtype=np.float64), (self.n,)).copy() for g in (kp, ki, kd))
        for name, g in (("kp", self.kp), ("ki", self.ki), ("kd", self.kd)):
            if not np.all(np.isfinite(g)):
                raise ValueError(f"{name}: non-finite gain")
        if tt is None:  # Astrom & Hagglund: Tt = sqrt(Ti Td) for PID, Ti for PI; none without integral action
            ki_safe = np.where(self.ki != 0, self.ki, 1.0)
            ti = np.abs(self.kp / ki_safe)
            td = np.abs(self.kd / np.where(self.kp != 0, self.kp, 1.0))
            tt_arr = np.where(td > 0, np.sqrt(ti * td), ti)
            self.tt = np.where((self.ki != 0) & (tt_arr > 0), np.maximum(tt_arr, self.dt), np.inf)
        else:
            self.tt = np.full(self.n, _pos("tt", tt))
        self.i = np.zeros(self.n)
        self.d = np.zeros(self.n)
        self.y_prev = np.zeros(self.n)
        self.u = np.zeros(self.n)
        self._fresh = np.ones(self.n, dtype=bool)

    def reset(self, mask: np.ndarray | None = None) -> None:
        """Zero the integrator, derivative filter and last output of the masked environments."""
        m = slice(None) if mask is None else np.asarray(mask, dtype=bool)
        self.i[m], self.d[m], self.u[m] = 0.0, 0.0, 0.0
        self._fresh[m] = True

    def engage(self, mask: np.ndarray | None, r: np.ndarray, y: np.ndarray, u_now: np.ndarray,
               ff: np.ndarray | float = 0.0, ydot: np.ndarray | None = None, gain_scale: np.ndarray | float = 1.0) -> None:
        """Bumpless engagement: choose I so that kp e + I - kd d + ff = u_now for the masked envs."""
        m = np.ones(self.n, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        g = np.broadcast_to(np.asarray(gain_scale, dtype=np.float64), (self.n,))
        r, y, u_now = (np.broadcast_to(np.asarray(a, dtype=np.float64), (self.n,)) for a in (r, y, u_now))
        ff = np.broadcast_to(np.asarray(ff, dtype=np.float64), (self.n,))
        d = np.zeros(self.n) if ydot is None else np.broadcast_to(np.asarray(ydot, dtype=np.float64), (self.n,))
        self.d[m] = d[m]
        self.y_prev[m] = y[m]
        self.u[m] = u_now[m]
        self.i[m] = (u_now - g * self.kp * (r - y) + g * self.kd * d - ff)[m]
        self._fresh[m] = False

    def update(self, r: np.ndarray, y: np.ndarray, ff: np.ndarray | float = 0.0, ydot: np.ndarray | None = None,
               gain_scale: np.ndarray | float = 1.0) -> np.ndarray:
        """One control step; returns the output u (n,) and keeps it for the rate limit."""
        r = np.asarray(r, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        g = np.asarray(gain_scale, dtype=np.float64)
        fresh = self._fresh
        if np.any(fresh):  # first step after reset: no derivative history, start from rest at y
            self.y_prev = np.where(fresh, y, self.y_prev)
            self._fresh = np.zeros(self.n, dtype=bool)
        raw = (y - self.y_prev) / self.dt if ydot is None else np.asarray(ydot, dtype=np.float64)
        a = self.dt / (self.tf + self.dt)
        self.d = np.where(fresh & (ydot is None), 0.0, self.d + a * (raw - self.d))
        self.y_prev = y.copy()
        e = r - y
        v = g * self.kp * e + self.i - g * self.kd * self.d + ff
        u = v
        if math.isfinite(self.rate):
            step = self.rate * self.dt
            u = np.where(fresh, u, np.clip(u, self.u - step, self.u + step))
        u = np.clip(u, self.u_min, self.u_max)
        gi = g * self.ki * e
        if self.antiwindup == "backcalc":
            self.i = self.i + self.dt * (gi + (u - v) / self.tt)
        else:
            pushing = ((u >= self.u_max) & (gi > 0)) | ((u <= self.u_min) & (gi < 0)) | (u != np.clip(v, self.u_min, self.u_max))
            self.i = self.i + np.where(pushing, 0.0, self.dt * gi)
        self.u = u
        return u
