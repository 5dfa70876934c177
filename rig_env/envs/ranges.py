"""The allowed ranges of the environments' sensor and loop settings, in a module that imports nothing: the
environments' configuration (:class:`rig_env.envs.config.RigEnvConfig`) checks its fields against them and
the rig process's artefact validation (:mod:`controllers.deploy.validate`) an artefact's, so that what an
environment can be built with and what the real-time loop flies are one set of numbers."""

from __future__ import annotations

MAX_AIRSPEED = 40.0
"""m/s: the Bristol 7x5 ft tunnel's working range for the rig (airspeeds in [0, MAX_AIRSPEED])."""
CONTROL_RATE_HZ = (1.0, 2000.0)
"""Hz: the real-time loop's rate (80 Hz on the rig, 244 Hz on the later one)."""
CONVERTER_BITS = (6, 24)
"""Resolution of the pots and encoders over one turn, bits (12 and 13 on the rig)."""
LINK_DELAY_STEPS = (0, 50)
"""Control steps of wireless telemetry delay (1 on the rig)."""
MAX_SEED = 2**32 - 1
"""The largest seed of a run: ``rig compare --seed`` and a ``--config`` file's ``seed`` (episode ``i`` of a run seeded
``s`` is the stream of seed ``s + i``, which then fits the int64 seeds the environments take for any number of
episodes), and the deployed loop's, the simulated rig's and its fault draws' (``rig-deploy run|sim-rig --seed``,
``--fault-seed``)."""
RATE_FILTER_MIN_HZ = 0.1
"""Hz: the rate estimate's low-pass corner at least this, at most half the control rate (its Nyquist frequency)."""
