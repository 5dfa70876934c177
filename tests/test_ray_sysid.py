"""Identification Monte-Carlo (``sysid.monte_carlo``): the Ray backend gives the local estimates, draw for draw."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import rig_env
from rig_env import sysid
from rig_env.params import PARAM_INDEX

D = math.pi / 180.0
NAMES = ["hawk_aero.CMalpha", "hawk_aero.CMq"]


@pytest.fixture(scope="module")
def clean() -> sysid.FlightRecord:
    p = rig_env.RigParams.default()
    test = sysid.three_two_one_one("hawk_elevator", -1.5)
    res = rig_env.simulate(p, [0.126], [0.0], 4.0, free_dofs=("model_pitch",), controls=test.controls())
    return sysid.FlightRecord.from_sim(res, surfaces=test.controls(), airspeed=20.0, name="pitch_3211")


def test_bad_options_name_themselves(clean: sysid.FlightRecord) -> None:
    p = rig_env.RigParams.default()
    with pytest.raises(ValueError, match=r"--backend 'dask': allowed \['local', 'ray'\]"):
        sysid.monte_carlo(clean, p, NAMES, noise_std_rad=0.1 * D, seeds=[0], backend="dask")
    with pytest.raises(ValueError, match="seeds = \\[1, 1\\]: a non-empty list of distinct integers"):
        sysid.monte_carlo(clean, p, NAMES, noise_std_rad=0.1 * D, seeds=[1, 1])
    with pytest.raises(ValueError, match=r"--chunk-size = 0: must be an integer in \[1, 100000\]"):
        sysid.monte_carlo(clean, p, NAMES, noise_std_rad=0.1 * D, seeds=[0], backend="ray", chunk_size=0)


def _local_in_fresh_process(clean: sysid.FlightRecord, seeds: list[int]) -> Any:
    """The local backend's Monte-Carlo in a fresh interpreter set up as the Ray workers are (their environment
    variables: one thread, the same numba cache), as a user's local run is; this test process has compiled
    other kernel variants on the way through the suite (README, "Not done yet").  The record goes by pickle
    between two processes of this test, never into the package."""
    import os
    import pickle
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    from rig_env.distributed import worker_env

    with tempfile.TemporaryDirectory() as tmp:
        rec, res = Path(tmp) / "clean.pkl", Path(tmp) / "local.pkl"
        rec.write_bytes(pickle.dumps(clean))
        code = ("import pickle, sys, math\n"
                "import rig_env\n"
                "from rig_env import sysid\n"
                "clean = pickle.loads(open(sys.argv[1], 'rb').read())\n"
                f"mc = sysid.monte_carlo(clean, rig_env.RigParams.default(), {NAMES!r}, noise_std_rad=0.1 * math.pi / 180.0, "
                f"seeds={seeds!r}, fit_kwargs={{'max_iter': 8}})\n"
                "open(sys.argv[2], 'wb').write(pickle.dumps(mc))\n")
        r = subprocess.run([sys.executable, "-c", code, str(rec), str(res)], env={**os.environ, **worker_env()},
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-3000:]
        return pickle.loads(res.read_bytes())


def test_ray_monte_carlo_equals_local(ray_cluster: Any, clean: sysid.FlightRecord) -> None:
    p = rig_env.RigParams.default()
    seeds = [11, 3, 7, 5, 2]  # any order: the result keeps it
    local = _local_in_fresh_process(clean, seeds)
    ray_mc = sysid.monte_carlo(clean, p, NAMES, noise_std_rad=0.1 * D, seeds=seeds, fit_kwargs={"max_iter": 8},
                               backend="ray", chunk_size=2)
    assert ray_mc.seeds == local.seeds == tuple(seeds)
    for n in NAMES:
        np.testing.assert_array_equal(ray_mc.estimates[n], local.estimates[n])
        np.testing.assert_array_equal(ray_mc.std[n], local.std[n])
    assert ray_mc.backend["chunks"] == 3 and ray_mc.backend["retries"] == 0
    assert local.flagged.shape == (5,) and not local.flagged.any()  # no draw of a good record is flagged (sysid.misfit_warnings)
    np.testing.assert_array_equal(ray_mc.flagged, local.flagged)
    assert local.estimates["hawk_aero.CMq"].std() > 0  # the draws differ (the noise is the seed's)
    s = local.summary({n: float(p.to_vector()[PARAM_INDEX[n]]) for n in NAMES})
    assert set(s["hawk_aero.CMq"]) == {"mean", "scatter", "mean_std", "ratio", "bias", "within_2std"}
