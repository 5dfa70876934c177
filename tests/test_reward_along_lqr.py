"""The free-flight reward along the designed law's path a = k a_LQR (scripts/reward_along_lqr.py): a reward that
trains as the task defines it must not prefer a weaker emulation than the criterion asks, and chatter on top of a
good command must still cost (the task's docstring, Reward)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
from reward_along_lqr import sweep  # noqa: E402


@pytest.fixture(scope="module")
def rows() -> dict[float, dict]:
    return {r["k"]: r for r in sweep("free_flight_emulation", [0.5, 1.0], 24, 30_000, rate_weights=[0.2])}


def test_free_flight_reward_prefers_the_full_lqr_to_half_of_it(rows):
    """At k = 1 the criterion's error is lower than at k = 0.5, and so must the reward be higher; with the shared
    rate weight (0.2) it was the other way round (the reason for the task's 0.02)."""
    half, full = rows[0.5], rows[1.0]
    assert full["median_emulation_error"] < half["median_emulation_error"]
    assert full["return"] > half["return"]
    assert full["return_w0.2"] < half["return_w0.2"]


def test_free_flight_chatter_on_the_lqr_costs():
    """A +-0.1 square wave at 2.5 Hz on top of the LQR's command earns less than the LQR alone."""
    clean, = sweep("free_flight_emulation", [1.0], 24, 30_000)
    chatter, = sweep("free_flight_emulation", [1.0], 24, 30_000, dither=(0.1, 2.5))
    assert chatter["return"] < clean["return"] - 2.0
