import os

import numpy as np
import pytest

import rig_env

# Ray on loopback only: Ray turns a 127.0.0.1 address into the machine's outward IP unless this is off
# (ray._private.services.get_node_ip_address); read when ray is first imported, so set before any test imports it
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")


@pytest.fixture(scope="session")
def params() -> rig_env.RigParams:
    return rig_env.RigParams.default()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


RAY_TEST_LIMIT_S = 900
"""A hard limit on each Ray test, and on the cluster's start and shutdown: a hung cluster ends the run with
status 1 (faulthandler's dump goes to pytest's fd capture, which the exit discards).  Armed per test, not over
the session: the session's cluster stays up until the last test, and the tests after the Ray ones must not
count against it (on a slow machine they did: the run ended 900 s after the cluster started, silently)."""


@pytest.fixture(autouse=True)
def _ray_test_watchdog(request: pytest.FixtureRequest):  # type: ignore[no-untyped-def]
    """:data:`RAY_TEST_LIMIT_S` over each test that uses ``ray_cluster``; nothing for the others."""
    if "ray_cluster" not in request.fixturenames:
        yield
        return
    import faulthandler
    import sys

    faulthandler.dump_traceback_later(RAY_TEST_LIMIT_S, exit=True, file=sys.__stderr__)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


@pytest.fixture(scope="session")
def ray_cluster():  # type: ignore[no-untyped-def]
    """A local multi-node Ray cluster on loopback (tests/test_ray_*.py): a head without CPUs (the driver, the
    books' actors) and two worker nodes of one CPU each; shut down at the end of the session.  Yields the
    ``ray.cluster_utils.Cluster``; a test that removes a node adds one back."""
    ray = pytest.importorskip("ray", reason="the Ray backend's tests need the extra: pip install -e '.[ray]'")
    import faulthandler
    import sys

    from ray.cluster_utils import Cluster

    from rig_env.distributed import worker_env

    from ray._private import ray_constants

    assert not ray_constants.ENABLE_RAY_CLUSTER, "ray was imported before tests/conftest.py chose loopback"
    faulthandler.dump_traceback_later(RAY_TEST_LIMIT_S, exit=True, file=sys.__stderr__)  # the cluster's start
    os.environ.setdefault("RAY_DEDUP_LOGS", "0")
    env = worker_env()
    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 0, "include_dashboard": False,
                                                             "node_ip_address": "127.0.0.1"})
    try:
        for _ in range(2):
            cluster.add_node(num_cpus=1, node_ip_address="127.0.0.1")
        ray.init(address=cluster.address, runtime_env={"env_vars": env}, logging_level="ERROR", log_to_driver=False)
        cluster.wait_for_nodes()
        faulthandler.cancel_dump_traceback_later()  # each test arms its own (_ray_test_watchdog)
        yield cluster
    finally:
        faulthandler.dump_traceback_later(RAY_TEST_LIMIT_S, exit=True, file=sys.__stderr__)  # the shutdown
        ray.shutdown()
        cluster.shutdown()
        faulthandler.cancel_dump_traceback_later()


@pytest.fixture
def nothing_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """rig compare fails the test if it gets as far as compiling or building anything: the option under test must be
    refused first (tests/test_compare_report.py, tests/test_compare_probe4.py)."""
    import controllers.evaluation.compare as cmp_mod

    def boom(*a: object, **k: object) -> None:
        raise AssertionError("the comparison started; the option should have been refused first")

    monkeypatch.setattr(cmp_mod, "precompile", boom)
    monkeypatch.setattr(cmp_mod, "_build", boom)
