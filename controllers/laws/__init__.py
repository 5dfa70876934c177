"""The control laws as they run: numpy only, what deploys.

Every law implements :class:`controllers.laws.base.Controller`, registers once under its kind with
:func:`~controllers.laws.base.register` and says which loop specs it takes
(:meth:`~controllers.laws.base.Controller.supports`).  A law is built from its designed tables
(plain data) and serialises itself to the one file format of every law, the rig-law artefact
(:mod:`controllers.laws.artefact`: ``law.to_data()``, ``cls.from_data(data, spec, num_envs)``, file
kind ``cls.artefact_kind``; this registry is the artefact's kind registry); it never imports its design (:mod:`controllers.design`), ``rig_env``, python-control,
scipy, numba or torch.

| kind | class | artefact kind | flies |
|---|---|---|---|
| ``"pid"`` | :class:`~controllers.laws.pid.PIDLaw` | ``pid`` | tasks with rig_roll free (cascaded roll, heave, sway loops) |
| ``"pid"`` | :class:`~controllers.laws.heave_sway.HeaveSwayPID` | ``pid_heave_sway`` | heave/sway tasks, rig_roll locked |
| ``"lqr"`` | :class:`~controllers.laws.lqr.LQRLaw` | ``lqr`` | tasks with rig_roll free (scheduled in airspeed and roll) |
| ``"lqr"`` | :class:`~controllers.laws.heave_sway.HeaveSwayLQR` | ``lqr_heave_sway`` | pull-up/push-over, forced oscillation |
| ``"lqr"`` | :class:`~controllers.laws.emulation.EmulationLQR` | ``lqr_emulation`` | free-flight emulation (model following) |
| ``"ppo"``, ``"sac"`` | :class:`~controllers.laws.rl.PPOPolicy`, :class:`~controllers.laws.rl.SACPolicy` | ``ppo``, ``sac`` | tasks with a trained policy (``controllers/policies/<task>_<kind>.json``) |
| ``"linear"`` | :class:`~controllers.laws.linear.LinearLaw` | ``linear`` | any (static feedback on the observation) |
"""

from controllers.laws import emulation, heave_sway, linear, lqr, pid, rl  # noqa: F401  (each registers its laws)
from controllers.laws.base import LAWS, Controller, LoopSpec, TabledLaw, UnsupportedTask, law_for, register

__all__ = ["LAWS", "Controller", "LoopSpec", "TabledLaw", "UnsupportedTask", "law_for", "register"]
