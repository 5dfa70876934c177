"""Several seeds of one training configuration: their final metrics, spread and curves (``rig train --seeds``).

One training run is an anecdote: PPO and SAC runs of the same settings differ by seed
(Henderson et al., *Deep Reinforcement Learning that Matters*, AAAI 2018).  :func:`summarise`
reads the policy artefacts the runs wrote (their provenance holds the final evaluation of the exported
policy and the evaluation curve) and writes

| file | content |
|---|---|
| ``seeds.json`` | per seed: final success rate, RMS error (deg), mean return, timesteps, wall time, when the target was reached; over seeds: mean, sample standard deviation (ddof 1; null for one seed), min, max |
| ``seeds.png`` | every seed's evaluation curve (success rate and mean return against timesteps) |

and prints the table.  Seeds of one summary must share task, algorithm and environment settings (a
ValueError names the first that differs).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

METRICS = ("success_rate", "rms_error_deg", "mean_return")


def summarise(policy_files: list[Path], out: Path, title: str, target: float) -> dict[str, Any]:
    """Summary of the runs behind ``policy_files`` (written to ``out/seeds.json`` and ``out/seeds.png``); returns it."""
    from controllers.laws.artefact import load

    if not policy_files:
        raise ValueError("policy_files: give at least one run")
    runs, first = [], None
    for f in policy_files:
        prov = load(f).provenance
        key = (prov.get("task"), prov.get("algo"), json.dumps(prov.get("env_overrides", {}), sort_keys=True))
        if first is None:
            first = key
        elif key != first:
            raise ValueError(f"{f}: task, algorithm or environment settings {key} differ from the first run's {first}")
        fin = prov["final_eval"]
        runs.append({"seed": prov["seed"], "policy": str(f), "timesteps": prov["timesteps"], "wall_time_s": prov["wall_time_s"],
                     "target_reached_at": prov.get("target_reached_at"), **{m: float(fin[m]) for m in METRICS},
                     "max_return": float(fin["max_return"]), "episodes": fin["episodes"],
                     "curve": prov["eval_during_training"]["curve"]})
    stats = {}
    for m in METRICS:
        v = np.array([r[m] for r in runs])
        stats[m] = {"mean": float(v.mean()), "std": float(v.std(ddof=1)) if v.size > 1 else None,
                    "min": float(v.min()), "max": float(v.max())}
    summary = {"task": first[0], "algo": first[1], "env_overrides": json.loads(first[2]), "seeds": [r["seed"] for r in runs],
               "final_eval": stats, "runs": [{k: v for k, v in r.items() if k != "curve"} for r in runs]}
    out.mkdir(parents=True, exist_ok=True)
    (out / "seeds.json").write_text(json.dumps(summary, indent=1) + "\n")
    _plot(runs, out / "seeds.png", title, target)
    print(f"\n{title}: {len(runs)} seeds")
    print(f"{'seed':>6s} {'success':>8s} {'RMS err':>8s} {'return':>9s} {'timesteps':>10s} {'wall s':>7s}")
    for r in runs:
        print(f"{r['seed']:6d} {r['success_rate']:8.2f} {r['rms_error_deg']:8.2f} {r['mean_return']:9.1f} {r['timesteps']:10d} {r['wall_time_s']:7.0f}")
    s = stats
    sd = {m: ("-" if s[m]["std"] is None else f"{s[m]['std']:.2f}") for m in METRICS}
    print(f"{'mean':>6s} {s['success_rate']['mean']:8.2f} {s['rms_error_deg']['mean']:8.2f} {s['mean_return']['mean']:9.1f}")
    print(f"{'std':>6s} {sd['success_rate']:>8s} {sd['rms_error_deg']:>8s} {sd['mean_return']:>9s}")
    print(f"wrote {out / 'seeds.json'} and {out / 'seeds.png'}", flush=True)
    return summary


def _plot(runs: list[dict[str, Any]], path: Path, title: str, target: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6.4, 5.4), dpi=100, sharex=True)
    for k, r in enumerate(runs):
        x = [p["timesteps"] for p in r["curve"]]
        a1.plot(x, [p["success_rate"] for p in r["curve"]], "o-", color=f"C{k % 10}", ms=3, label=f"seed {r['seed']}")
        a2.plot(x, [p["mean_return"] for p in r["curve"]], "o-", color=f"C{k % 10}", ms=3)
    a1.axhline(target, color="0.5", lw=0.8, ls=":")
    a1.set_ylim(-0.02, 1.02)
    a1.set_ylabel("eval success rate")
    a2.set_ylabel("mean eval return")
    a2.set_xlabel("timesteps")
    a1.legend(fontsize=8, ncol=min(len(runs), 5))
    a1.set_title(f"{title}: {len(runs)} seeds", fontsize=10)
    for a in (a1, a2):
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
