"""Deployment loop: latency and jitter at 80 and 244 Hz against the sim rig, and the runtime's per-call cost per kind.

    python benchmarks/bench_deploy.py [--seconds 10] [--rates 80 244] [--realtime] [--write]
    python benchmarks/bench_deploy.py --runtime-only          # only the per-kind runtime cost (no loop runs)

Loop runs: the sim rig (``scripts/deploy.py sim-rig``) in a subprocess, the loop in this process,
loopback UDP, the "linear" law exported at each rate.  Latency = command sent - tick deadline; wake
jitter = wake-up - deadline; a deadline miss = the command left after the rig's next tick (0.75 period
after the loop's deadline).  ``--realtime`` runs both sides under SCHED_FIFO as well (a second row).
Runtime cost: ``act`` of each exportable kind (one environment, float32 observation in, after 200
warm-up calls), median over 20,000 calls, for every kind in ``controllers.CONTROLLERS`` plus "linear"
("pid", "lqr", and "ppo" / "sac" when installed), plus the observation builder (``Sensors.update`` +
``observe``).  ``--write`` replaces the "## Deployment loop" section of benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = str(ROOT / "scripts" / "deploy.py")
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
TASK = "velocity_vector_roll"
NOTE = ("Columns: a deadline miss is a command sent after the rig's next tick (0.75 period after the deadline); "
        "missed frames are ticks that found no new sensor frame even after the bounded wait.  Normal-scheduling rows "
        "include the machine's run-queue delays; SCHED_FIFO rows (--realtime, loop and sim rig) show the loop without them.")


def export(kind: str, rate: float, out: Path) -> str | None:
    """None on success, else the reason the kind is not available."""
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", kind, "--task", TASK, "--rate", str(rate), "--out", str(out)],
                       env=ENV, capture_output=True, text=True, timeout=600)
    return None if r.returncode == 0 else (r.stderr.strip().splitlines() or ["?"])[-1]


def loop_run(law: Path, rate: float, seconds: float, realtime: bool) -> dict:
    from controllers.deploy import load
    from controllers.deploy.loop import LoopConfig, RigLoop

    cmd = [sys.executable, SCRIPT, "sim-rig", "--port", "0", "--task", TASK, "--rate", str(rate), "--duration", str(seconds)]
    rig = subprocess.Popen(cmd + (["--realtime"] if realtime else []), env=ENV, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        port = json.loads(rig.stdout.readline())["listening"][1]
        loop = RigLoop(load(law), LoopConfig(rig=("127.0.0.1", port), rate_hz=rate, bind=("127.0.0.1", 0), duration=seconds, arm=True, realtime=realtime))
        out: dict = {}
        th = threading.Thread(target=lambda: out.update(loop.run()))
        th.start()
        th.join(seconds + 60)
        rig.wait(timeout=60)
        return out
    finally:
        if rig.poll() is None:
            rig.kill()


def runtime_cost(law: Path, calls: int = 20_000) -> float:
    from controllers.deploy import load

    ctrl = load(law).controller()
    obs = np.random.default_rng(0).uniform(-1, 1, (1, ctrl.spec.obs_dim)).astype(np.float32)
    for _ in range(200):
        ctrl.act(obs)
    t = np.empty(calls)
    for i in range(calls):
        t0 = time.perf_counter()
        ctrl.act(obs)
        t[i] = time.perf_counter() - t0
    return float(np.median(t))


def observation_cost(law: Path, calls: int = 20_000) -> float:
    from controllers.deploy import load
    from rig_env.envs.observation import observe, task_for_seed
    from rig_env.envs.sensors import Sensors

    spec = load(law).spec
    s = Sensors(1, spec.free_dofs, spec.dt, delay_steps=0, quantise=False)
    task = task_for_seed(spec.task, spec.free_dofs, spec.dt, 20.0, 0)
    a, f, v, tt = np.zeros((1, len(spec.free_dofs))), np.zeros((1, 4)), np.full(1, 20.0), np.zeros(1)
    t0 = time.perf_counter()
    for i in range(calls):
        s.update(a, f, v)
        tt[0] = i * spec.dt
        observe(s, task, tt)
    return (time.perf_counter() - t0) / calls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--rates", type=float, nargs="+", default=[80.0, 244.0])
    ap.add_argument("--realtime", action="store_true")
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--runtime-only", action="store_true", help="skip the loop runs; measure the kinds' runtime cost only")
    a = ap.parse_args()
    if a.runtime_only and a.write:
        ap.error("--write replaces the whole section: run it without --runtime-only")
    sys.path.insert(0, str(ROOT))
    from benchmarks.bench_step import machine_line

    lines = [f"Command: `python benchmarks/bench_deploy.py --seconds {a.seconds:g}{' --realtime' if a.realtime else ''}`.  Machine: {machine_line()}.", ""]
    if not a.runtime_only:
        lines += ["| rate | scheduling | ticks | deadline misses | latency p50 / p99 / max, ms | wake jitter std / p99 / max, ms | missed frames | law act p50, ms |",
                  "|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for rate in ([] if a.runtime_only else a.rates):
            law = Path(tmp) / f"linear_{rate:g}.json"
            assert export("linear", rate, law) is None
            for rt in ([False, True] if a.realtime else [False]):
                s = loop_run(law, rate, a.seconds, rt)
                L, J, C = s["latency"], s["wake_jitter"], s["compute"]
                sched = "SCHED_FIFO" if rt and not any(e["event"] == "realtime_refused" for e in s["events"]) else "normal"
                lines.append(f"| {rate:g} Hz | {sched} | {s['ticks']} | {s['deadline_misses']} ({100 * s['deadline_miss_fraction']:.2f} %) | "
                             f"{L['p50_ms']:.2f} / {L['p99_ms']:.2f} / {L['max_ms']:.2f} | {J['std_ms']:.2f} / {J['p99_ms']:.2f} / {J['max_ms']:.2f} | "
                             f"{s['counts']['missed']} | {C['p50_ms']:.3f} |")
                print(lines[-1], flush=True)
        lines += ["", "| artefact kind (exported from) | runtime `act`, median per call | note |", "|---|---|---|"]
        from controllers.laws.base import CONTROLLERS
        import controllers  # noqa: F401

        for kind in ["linear"] + sorted(k for k in CONTROLLERS if k != "linear"):
            law = Path(tmp) / f"{kind}.json"
            why = export(kind, 80.0, law)
            if why:
                lines.append(f"| {kind} | - | not exportable here: {why} |")
            else:
                lines.append(f"| {json.loads(law.read_text())['kind']} ({kind}) | {runtime_cost(law) * 1e6:.1f} us | |")
            print(lines[-1], flush=True)
        lines.append(f"| observation builder (`Sensors.update` + `observe`) | {observation_cost(Path(tmp) / 'linear.json') * 1e6:.1f} us | per tick, shared with the envs |")
    if not a.runtime_only:
        lines += ["", NOTE]
    text = "\n".join(lines)
    print(text)
    if a.write:
        path = ROOT / "benchmarks" / "RESULTS.md"
        old = path.read_text()
        head, sep, rest = old.partition("\n## Deployment loop\n")
        tail = ""
        if sep:
            nxt = rest.find("\n## ")
            tail = rest[nxt:] if nxt >= 0 else ""
        path.write_text(head.rstrip("\n") + "\n\n## Deployment loop\n\n" + text + "\n" + tail)


if __name__ == "__main__":
    main()
