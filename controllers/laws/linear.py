"""``LinearLaw``: static linear state feedback on the observation, with output and rate limits (artefact kind "linear").

Per control step ``dt`` (batched over environments, numpy only)::

    v_k = clip(K (obs_k - obs0) + u0, -1, 1)                 K: (n_a, obs_dim), obs0: (obs_dim,), u0: (n_a,)
    u_k = u_{k-1} + clip(v_k - u_{k-1}, -r dt, r dt)           r: (n_a,) rate limit, action units / s
    u_{-1} = 0 after reset (surfaces at neutral, as the environments start)

Actions are normalised (1 = ``spec.action_scale_deg``).  This is what an LQR exports to (``K = -K_lqr
M`` with ``M`` the map from observation entries to the design state, ``obs0`` the trim observation,
``u0`` the trim command), so the artefact kind ``"linear"`` serves both.
:func:`controllers.design.linear.roll_tracking` designs the simple roll-tracking law the deployment
tests fly.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from controllers.laws.base import Controller, LoopSpec, register
from controllers.laws.signals import real_array


@register("linear")
class LinearLaw(Controller):
    """u = clip(K (obs - obs0) + u0, -1, 1) with a rate limit; see the module docstring.

    | argument | shape | unit |
    |---|---|---|
    | K | (n_actions, obs_dim) | action units per observation unit |
    | obs0 | (obs_dim,) | observation units (default 0) |
    | u0 | (n_actions,) | action units, in [-1, 1] (default 0) |
    | rate_limit | (n_actions,) | action units / s, > 0 (default 350/40: the servos' 350 deg/s) |
    """

    artefact_kind = "linear"
    built_from_spec = False  # its gains are arguments (make_controller("linear", spec, K=...))

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, K: np.ndarray, obs0: np.ndarray | None = None,
                 u0: np.ndarray | None = None, rate_limit: np.ndarray | None = None) -> None:
        super().__init__(spec, num_envs)
        na, no = spec.n_actions, spec.obs_dim
        self.K = _arr("K", K, (na, no))
        self.obs0 = _arr("obs0", np.zeros(no) if obs0 is None else obs0, (no,))
        self.u0 = _arr("u0", np.zeros(na) if u0 is None else u0, (na,))
        if np.any(np.abs(self.u0) > 1.0):
            raise ValueError(f"u0 = {self.u0.tolist()}: each entry must be in [-1, 1]")
        self.rate_limit = _arr("rate_limit", np.full(na, 350.0 / spec.action_scale_deg) if rate_limit is None else rate_limit, (na,))
        if np.any(self.rate_limit <= 0.0):
            raise ValueError(f"rate_limit = {self.rate_limit.tolist()}: each entry must be > 0 (action units / s)")
        self._du = self.rate_limit * spec.dt
        self.u = np.zeros((self.num_envs, na))

    def to_data(self) -> dict[str, Any]:
        return {"K": self.K.copy(), "obs0": self.obs0.copy(), "u0": self.u0.copy(), "rate_limit": self.rate_limit.copy()}

    @classmethod
    def from_data(cls, data: Mapping[str, Any], spec: LoopSpec, num_envs: int = 1) -> LinearLaw:
        missing = [k for k in ("K", "obs0", "u0", "rate_limit") if k not in data]
        if missing:
            raise ValueError(f"linear: missing array(s) {missing}")
        return cls(spec, num_envs, K=data["K"], obs0=data["obs0"], u0=data["u0"], rate_limit=data["rate_limit"])

    @classmethod
    def data_of(cls, law: Controller) -> dict[str, Any]:
        """A LinearLaw's data, or ``law.linear_form()`` (a dict with K, obs0, u0, rate_limit) of another law that is
        static and linear in its observation (it sets ``artefact_kind = "linear"`` and provides the method)."""
        if isinstance(law, cls):
            return law.to_data()
        form = getattr(law, "linear_form", None)
        if form is None:
            raise TypeError(f"kind 'linear' stores a LinearLaw or a law with linear_form(); got {type(law).__name__}")
        d = dict(form())
        unknown = sorted(set(d) - {"K", "obs0", "u0", "rate_limit"})
        if unknown:
            raise ValueError(f"linear_form(): unknown key(s) {unknown}; allowed K, obs0, u0, rate_limit")
        return LinearLaw(law.spec, 1, **d).to_data()  # validates shapes and values, fills the defaults

    def reset(self, mask: np.ndarray | None = None) -> None:
        self.u[self._mask(mask)] = 0.0

    def act(self, obs: np.ndarray) -> np.ndarray:
        o = self._check_obs(obs)
        v = np.clip((o - self.obs0) @ self.K.T + self.u0, -1.0, 1.0)
        self.u += np.clip(v - self.u, -self._du, self._du)
        return self.u.copy()


def _arr(name: str, v: Any, shape: tuple[int, ...]) -> np.ndarray:
    a = np.array(real_array(name, v, f"an array of shape {shape}"))  # a copy: the law keeps it
    if a.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: non-finite value(s)")
    return a

