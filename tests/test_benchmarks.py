"""The benchmarks' kernel steppers still run against the kernels' current interfaces.

Timing lives in ``benchmarks/`` (never in tests); this only steps each stepper of
``benchmarks/bench_step.py`` (also used by ``benchmarks/bench_compile.py``) on a few environments, so that a
change of a kernel's signature cannot leave a benchmark broken unnoticed (``lanes.new_work`` gained its
``n_sub`` argument and ``bench_step.py`` failed until the next benchmark run found it).
"""

import numpy as np
import pytest

from benchmarks import bench_step as b


def test_lane_and_joint_steppers_agree(params):
    """The lane kernel and the per-environment kernel, as the benchmark drives them, end one env-step at
    the same state (they are the same model; the lane kernel differs in the order of some operations)."""
    out = {}
    for name in ("lanes_stepper", "joint_stepper"):
        a = b.setup(params, 9)  # 9: one full block of 8 lanes and one partial
        step = getattr(b, name)(a)
        for _ in range(3):
            step()
        assert np.all(a["status"] == 0)
        out[name] = a["X"].copy()
    assert np.all(np.isfinite(out["lanes_stepper"]))
    np.testing.assert_allclose(out["lanes_stepper"], out["joint_stepper"], rtol=0, atol=1e-11)


def test_dae_stepper_runs(params):
    """The DAE stepper (its state lives inside the stepper) takes env-steps without flagging an environment."""
    a = b.setup(params, 2)
    step = b.dae_stepper(a)
    for _ in range(3):
        step()
    assert np.all(a["status"] == 0)


def test_rate_counts_env_steps():
    """rate() counts n env-steps per call: at least min_calls timed calls after the warm-up call, and a
    positive wall and CPU rate."""
    calls = []
    best, per_cpu = b.rate(lambda: calls.append(1), 64, seconds=0.01, min_calls=3, repeats=1)
    assert len(calls) >= 1 + 3 and best > 0 and per_cpu > 0


def test_autoreset_bench_times_both_modes():
    """benchmarks/bench_autoreset.py on a tiny batch: both modes step, one rate per round."""
    from benchmarks import bench_autoreset

    r = bench_autoreset.bench(2, 0.1, 0.01, 2)
    assert sorted(r) == ["NextStep", "SameStep"] and all(len(v) == 2 and min(v) > 0 for v in r.values())


def test_aero_models_bench_reports_each_rounds_ratio(capsys):
    """benchmarks/bench_aero_models.py on the lane kernels only: a ratio per round (each the round's own unsteady
    rate over its linear one) and their median; the per-environment kernels are not built."""
    from benchmarks import bench_aero_models

    out = bench_aero_models.main(["--envs", "8", "--seconds", "0.05", "--rounds", "2", "--serial", "--kinds", "lanes", "--json"])
    per_round = out["unsteady_over_linear_lanes_cpu_per_round/8"]
    assert len(per_round) == 2 and all(r > 0 for r in per_round)
    assert out["unsteady_over_linear_lanes_cpu_median/8"] == pytest.approx(0.5 * (per_round[0] + per_round[1]), rel=1e-12)
    assert set(out["rates"]) == {f"{m}/lanes/8" for m in ("linear", "tables", "unsteady")}
    assert "linear_lanes_over_joint/8" not in out


def test_aero_models_sandwich_divides_each_unsteady_window_by_its_two_linear_neighbours(monkeypatch):
    """--sandwich: ratio k is unsteady window k over the mean of the linear windows k and k + 1 (the linear
    rates drift here, the unsteady ones do not: a drift the neighbours' mean takes out exactly)."""
    from benchmarks import bench_aero_models

    linear = iter([100.0, 120.0, 140.0, 160.0])
    unsteady = iter([88.0, 104.0, 120.0])
    steps = {"linear": lambda: None, "unsteady": lambda: None}
    monkeypatch.setattr(bench_aero_models, "stepper", lambda params, n, model, kind, parallel=None: (steps[model], kind))
    monkeypatch.setattr(bench_aero_models, "cpu_window", lambda step, n, seconds: next(linear if step is steps["linear"] else unsteady))
    out = bench_aero_models.sandwich(None, [8], 3, 0.01, True, {})
    r = out["unsteady_over_linear_lanes_sandwich/8"]
    assert r["ratios"] == pytest.approx([88 / 110, 104 / 130, 120 / 150], rel=1e-12)
    assert r["median"] == pytest.approx(0.8, rel=1e-12) and r["q25"] <= r["median"] <= r["q75"]


def test_aero_models_sandwich_runs_on_the_lane_kernels_and_refuses_a_bad_count(capsys):
    """--sandwich on a tiny batch: one positive ratio per triple; a negative count or window is refused naming it."""
    from benchmarks import bench_aero_models

    out = bench_aero_models.main(["--envs", "8", "--sandwich", "3", "--window", "0.02", "--json"])
    assert len(out["unsteady_over_linear_lanes_sandwich/8"]["ratios"]) == 3
    assert all(r > 0 for r in out["unsteady_over_linear_lanes_sandwich/8"]["ratios"])
    for bad in (["--sandwich", "-1"], ["--window", "0"]):
        with pytest.raises(SystemExit):
            bench_aero_models.main(["--envs", "8", *bad])
        assert bad[0] in capsys.readouterr().err


def test_continuation_bench_times_both_orbit_kernels_and_finds_the_same_orbits():
    """benchmarks/bench_continuation.py with two orbits per family: a time per kernel and round, and the lane and
    per-environment kernels' orbits the same (they integrate the same model, to 1e-10 per step)."""
    from benchmarks import bench_continuation

    out = bench_continuation.run("lower", 1, 2)
    assert len(out["seconds"]["lanes"]) == len(out["seconds"]["joint"]) == 1 and out["ratios"][0] > 0
    assert len(out["orbits"]) == 1 and out["orbits"][0] >= 2  # one family (the second Hopf point starts none)
    assert out["max_value_difference"] < 1e-6 and out["max_amplitude_difference"] < 1e-6
