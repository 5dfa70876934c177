"""Design of a :class:`controllers.laws.linear.LinearLaw`: the roll-tracking law the deployment tests fly.

:func:`roll_tracking` is a proportional-derivative law on the task's roll-error entries with
reference-rate feed-forward: a legitimate law with hand-set gains in observation units, not a tuned
design.
"""

from __future__ import annotations

import numpy as np

from controllers.laws.base import LoopSpec
from controllers.laws.linear import LinearLaw


def roll_tracking(spec: LoopSpec, kp: float = 2.0, kd: float = 1.0, kff: float = 1.0) -> LinearLaw:
    """Compensator aileron = kp roll_error + kd roll-rate error + kff roll_rate_ref (observation units).

    Uses the task entries ``roll_error`` and ``roll_rate_error``/``roll_rate_ref`` when the task has
    them, else ``-rig_roll_rate`` as the rate error (a step reference has zero reference rate).  ValueError unless
    ``kp``, ``kd``, ``kff`` are finite real numbers.
    """
    for name, g in (("kp", kp), ("kd", kd), ("kff", kff)):  # a string "2" was converted by numpy without a word
        if isinstance(g, (bool, np.bool_)) or not isinstance(g, (int, float, np.integer, np.floating)) or not np.isfinite(g):
            raise ValueError(f"{name} = {g!r}: must be a finite number")
    if "roll_error" not in spec.obs_labels:
        raise ValueError(f"task {spec.task!r}: the roll-tracking law needs an observation entry 'roll_error'; entries: {list(spec.obs_labels)}")
    K = np.zeros((spec.n_actions, spec.obs_dim))
    a = spec.action_index("comp_aileron")
    K[a, spec.index("roll_error")] = kp
    if "roll_rate_error" in spec.obs_labels:
        K[a, spec.index("roll_rate_error")] = kd
        K[a, spec.index("roll_rate_ref")] = kff
    else:
        K[a, spec.index("rig_roll_rate")] = -kd
    return LinearLaw(spec, 1, K=K)
