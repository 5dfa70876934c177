"""The law registry: every kind routes every task's spec to at most one class, by its ``supports``, never by import order."""

from __future__ import annotations

import numpy as np
import pytest

from controllers import LAWS, Controller, LoopSpec, UnsupportedTask, law_for, make_controller
from controllers.laws.base import register
from controllers.laws.emulation import EmulationLQR
from controllers.laws.heave_sway import HeaveSwayLQR, HeaveSwayPID
from controllers.laws.lqr import LQRLaw
from controllers.laws.pid import PIDLaw
from rig_env.envs import TASKS, RigVectorEnv

SPECS = [(t, {}) for t in sorted(TASKS)] + [("forced_oscillation", {"axis": "sway_yaw"})]
ROUTES = {  # (task, kind) -> the class the task's default joint set gets
    ("velocity_vector_roll", "pid"): PIDLaw, ("velocity_vector_roll", "lqr"): LQRLaw,
    ("bank_to_bank", "pid"): PIDLaw, ("bank_to_bank", "lqr"): LQRLaw,
    ("departure_recovery", "pid"): PIDLaw, ("departure_recovery", "lqr"): LQRLaw,
    ("pull_up_push_over", "pid"): HeaveSwayPID, ("pull_up_push_over", "lqr"): HeaveSwayLQR,
    ("forced_oscillation", "pid"): HeaveSwayPID, ("forced_oscillation", "lqr"): HeaveSwayLQR,
    ("free_flight_emulation", "pid"): HeaveSwayPID, ("free_flight_emulation", "lqr"): EmulationLQR,
}


def _spec(task: str, opts: dict) -> LoopSpec:
    return LoopSpec.from_env(RigVectorEnv(1, task=task, task_options=opts))


@pytest.mark.parametrize("task, opts", SPECS)
def test_every_kind_routes_each_spec_to_one_class_or_says_why_not(task, opts):
    spec = _spec(task, opts)
    for kind, classes in LAWS.items():
        takers = [c for c in classes if c.supports(spec) is None]
        assert len(takers) <= 1, (kind, takers)
        if takers:
            assert law_for(kind, spec) is takers[0]
        else:
            with pytest.raises(UnsupportedTask, match=kind):
                law_for(kind, spec)
        if (task, kind) in ROUTES:
            assert takers == [ROUTES[(task, kind)]]


def test_supports_is_what_routes_not_the_import_order():
    """Reversing the registration order of every kind changes no route."""
    spec = {(t, tuple(o.items())): _spec(t, o) for t, o in SPECS}
    before = {(k, s): law_for(k, spec[s]) for k in ("pid", "lqr") for s in spec}
    saved = {k: list(v) for k, v in LAWS.items()}
    try:
        for v in LAWS.values():
            v.reverse()
        assert {(k, s): law_for(k, spec[s]) for k in ("pid", "lqr") for s in spec} == before
    finally:
        LAWS.clear()
        LAWS.update(saved)


def test_a_spec_claimed_twice_is_refused_and_an_unknown_kind_named():
    spec = _spec("velocity_vector_roll", {})

    class _A(Controller):
        def reset(self, mask=None):
            pass

        def act(self, obs):
            return np.zeros((self.num_envs, self.spec.n_actions))

    class _B(_A):
        artefact_kind = "_twice_b"  # one class per artefact kind

    try:
        register("_twice")(_A), register("_twice")(_B)
        with pytest.raises(ValueError, match="all claim task 'velocity_vector_roll'"):
            law_for("_twice", spec)
    finally:
        LAWS.pop("_twice", None)
    with pytest.raises(ValueError, match="unknown; known kinds"):
        make_controller("no_such_law", spec)
