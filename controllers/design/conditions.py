"""The randomised conditions laws are trained and evaluated under (:data:`MODES`: nominal, robust, gusty).

Defined here, below both users: RL training (:mod:`controllers.design.rl_train`, ``--conditions``) and
the evaluation (:mod:`controllers.evaluation.evaluate`, which documents the table of conditions and
re-exports these names).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any, Mapping

from rig_env.envs.tasks import TASKS
from rig_env.params import JOINTS, RigParams

_AERO_DERIVATIVES = [f"hawk_aero.{k}" for k in ("CLalpha", "CLq", "CLde", "CMalpha", "CMq", "CMde", "CYbeta", "CYdr", "Clbeta",
                                                  "Clp", "Clr", "Clda", "Cldr", "Cnbeta", "Cnp", "Cnr", "Cnda", "Cndr")]
_AERO_DERIVATIVES += [f"comp_aero.{k}" for k in ("CLalpha", "CLq", "CLde", "CMalpha", "CMq", "CMde")]
_FRICTION = [f"friction.{j}.{k}" for j in JOINTS for k in ("Fs", "Fc", "sigma2")]


def _spread(names: list[str], frac: float, params: RigParams | None = None) -> dict[str, tuple[float, float]]:
    """``name -> (lo, hi)``: +-frac around the default value of every non-zero parameter in names."""
    p = params or RigParams.default()
    out = {}
    for k in names:
        v = float(functools.reduce(getattr, k.split("."), p))
        if v != 0.0:
            a, b = v * (1 - frac), v * (1 + frac)
            out[k] = (min(a, b), max(a, b))
    return out


def _nominal_randomise(params: RigParams | None = None) -> dict[str, tuple[float, float]]:
    r = _spread(["mass.hawk_mass"], 0.10, params)
    r["servos.compensator.delay_s"] = (0.010, 0.020)
    r["servos.compensator.natural_freq_hz"] = (5.0, 8.0)
    return r


@dataclass(frozen=True)
class Conditions:
    """Randomised conditions of an evaluation; fields are :class:`rig_env.envs.RigEnvConfig` settings."""

    name: str
    airspeed: tuple[float, float] = (15.0, 25.0)
    turbulence: float = 0.01
    randomise: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    angle_noise_deg: float = 0.05
    link_delay_steps: int = 1

    def env_fields(self, task: str | None = None) -> dict[str, Any]:
        """The :class:`rig_env.envs.RigEnvConfig` settings; with ``task`` its airspeed floor applied
        (``Task.airspeed_for``: the roll tasks fly from 17 m/s, where the default rig can hold 90 deg of bank)."""
        airspeed = self.airspeed if task is None else TASKS[task].airspeed_for(self.airspeed)
        return {"airspeed": airspeed, "turbulence": self.turbulence, "randomise": dict(self.randomise),
                "angle_noise_deg": self.angle_noise_deg, "link_delay_steps": self.link_delay_steps}


NOMINAL = Conditions("nominal", randomise=_nominal_randomise())
ROBUST = Conditions("robust", randomise={**_nominal_randomise(), **_spread(_AERO_DERIVATIVES + _FRICTION, 0.20)})
GUSTY = Conditions("gusty", turbulence=0.05, randomise=_nominal_randomise())
"""A stress case, not run by default: 5 % gusts are atmospheric, five times a working tunnel's."""
MODES = {"nominal": NOMINAL, "robust": ROBUST, "gusty": GUSTY}


def modes_for(params: RigParams | None = None) -> dict[str, Conditions]:
    """:data:`MODES` with their +-fraction spreads centred on ``params``' values (an identified rig)
    instead of the default rig's; the measured ranges (servo delay and bandwidth) stay as they are."""
    nominal = _nominal_randomise(params)
    return {"nominal": Conditions("nominal", randomise=nominal),
            "robust": Conditions("robust", randomise={**nominal, **_spread(_AERO_DERIVATIVES + _FRICTION, 0.20, params)}),
            "gusty": Conditions("gusty", turbulence=GUSTY.turbulence, randomise=nominal)}
