import numpy as np
import pytest

import rig_env


@pytest.fixture(scope="session")
def params() -> rig_env.RigParams:
    return rig_env.RigParams.default()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
