"""Which law for a task: the documented score, the success criterion, ties and caveats.

Each episode ``i`` of a law gets a score

    s_i = success_i - W_SAT * saturation_i - W_CHATTER * min(1, cmd_rate_rms_i / RATE_REF) - W_STOP * min(1, stop_time_i / STOP_REF)

with ``success_i`` 1 or 0 (the task's own criterion), ``saturation_i`` the fraction of the episode some
command sat within 2 % of its +-40 deg limit, ``cmd_rate_rms_i`` the RMS rate of the busiest surface's
command, deg/s, against ``RATE_REF`` = 350 deg/s (the servos' slew rate: a command that moves that fast
on average is chatter), and ``stop_time_i`` the time a joint spent on a stop, s, against ``STOP_REF`` =
1 s (per-episode metrics: :mod:`controllers.evaluation.traces`).  The weights (:class:`ScoreRule`,
defaults 0.5, 0.25, 0.5) make a law that succeeds every time but holds a surface on its limit (or a joint
on a stop) score 0.5, and one that slews as fast as the servos can 0.75.  A law's score is the mean of its
episodes' scores, 1 at best, with a 95 % bootstrap interval (:func:`controllers.evaluation.stats.bootstrap_ci`).

The recommendation for a task and mode (:func:`recommend`):

1. eligible laws: success rate (point estimate) at least ``ScoreRule.min_success`` (80 %);
2. none eligible: no law is recommended (``law`` null), the first caveat says "no law meets the
   criterion" and names the best success rate with its interval;
3. otherwise the eligible laws are ranked by score; when the top law's score interval overlaps another
   eligible law's, that is a tie: ``law`` is null, ``tied`` names them, and a caveat says so;
4. caveats for the top law: a success interval reaching below the criterion (too few episodes to be sure),
   saturation (median >= 5 % of the episode), a command rate RMS of half the slew reference or more, a
   dominant command oscillation of 2 Hz or more and +-5 deg or more, stop contact, an RMS error over two or
   more reference steps dominated by the steps (hold error below half the RMS error);
5. episodes that every law failed (with two or more laws; :func:`shared_failures`): the episodes are paired, the
   same draw for every law, so a draw that defeats them all points at the rig's reach or the task (a hold
   beyond the compensator's trim authority, an airspeed too low for the aileron against the roll imbalance)
   rather than at any one law.  The caveat names how many, their episodes and their airspeeds, and
   ``shared_failures`` carries them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Mapping, Sequence

import numpy as np

from controllers.evaluation.stats import bootstrap_ci


@dataclass(frozen=True)
class ScoreRule:
    """The score's weights and references, and the success criterion (module docstring)."""

    min_success: float = 0.8
    w_saturation: float = 0.5
    w_chatter: float = 0.25
    w_stop: float = 0.5
    rate_ref_deg_s: float = 350.0
    stop_ref_s: float = 1.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            lo, hi = (0.0, 1.0) if f.name == "min_success" else ((0.0, 10.0) if f.name.startswith("w_") else (1e-9, 1e6))
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (lo <= v <= hi):
                raise ValueError(f"score.{f.name} = {v!r}: must be a number in [{lo:g}, {hi:g}]")

    def describe(self) -> str:
        """The formula with these numbers, for the report."""
        return (f"score = mean over episodes of success - {self.w_saturation:g} saturated fraction "
                f"- {self.w_chatter:g} min(1, command rate RMS / {self.rate_ref_deg_s:g} deg/s) "
                f"- {self.w_stop:g} min(1, time on stops / {self.stop_ref_s:g} s); "
                f"eligible: success >= {100 * self.min_success:.0f} %; a tie when 95 % score intervals overlap")

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


DEFAULT_RULE = ScoreRule()


def episode_scores(m: Mapping[str, np.ndarray], rule: ScoreRule = DEFAULT_RULE) -> np.ndarray:
    """(n,) scores of a law's episodes from its metrics (``success``, ``saturation``, ``cmd_rate_rms``, ``stop_time``)."""
    z = lambda k: np.nan_to_num(np.asarray(m[k], dtype=float), nan=0.0)  # noqa: E731
    return (z("success") - rule.w_saturation * z("saturation") - rule.w_chatter * np.minimum(1.0, z("cmd_rate_rms") / rule.rate_ref_deg_s)
            - rule.w_stop * np.minimum(1.0, z("stop_time") / rule.stop_ref_s))


def law_score(m: Mapping[str, np.ndarray], rule: ScoreRule = DEFAULT_RULE, seed: int = 0) -> tuple[float, tuple[float, float]]:
    """The law's score (mean of :func:`episode_scores`) and its 95 % bootstrap interval."""
    s = episode_scores(m, rule)
    return float(np.mean(s)), bootstrap_ci(s, np.mean, seed=seed)


def _pct(x: float) -> str:
    return f"{100 * x:.0f}"


def _caveats(law: str, r: Mapping[str, Any], rule: ScoreRule) -> list[str]:
    """Caveats about one law from its row (:func:`controllers.evaluation.summary.row_of`)."""
    out = []
    lo, hi = r["success_ci95"]
    med = lambda k: r["metrics"][k]["median"]  # noqa: E731
    if r["success"] >= rule.min_success and lo < rule.min_success:
        out.append(f"{law}: success {_pct(r['success'])} % [{_pct(lo)}, {_pct(hi)}] of {r['episodes']} episodes does not exclude "
                   f"a rate below {_pct(rule.min_success)} %; more episodes would narrow the interval")
    sat = med("saturation")  # % of the episode
    if np.isfinite(sat) and sat >= 5.0:
        out.append(f"{law}: a command saturated (within 2 % of +-40 deg) {sat:.0f} % of the time (median over episodes)")
    rate = med("cmd_rate_rms")
    if np.isfinite(rate) and rate >= 0.5 * rule.rate_ref_deg_s:
        out.append(f"{law}: command rate RMS {rate:.0f} deg/s, {_pct(rate / rule.rate_ref_deg_s)} % of the servos' "
                   f"{rule.rate_ref_deg_s:g} deg/s slew rate")
    f, amp = med("cmd_freq"), med("cmd_osc_amp")
    if np.isfinite(f) and np.isfinite(amp) and f >= 2.0 and amp >= 5.0:
        out.append(f"{law}: the command oscillates at {f:.1f} Hz, +-{amp:.0f} deg (median dominant component)")
    on_stop = r.get("stop_episodes", 0)
    if on_stop:
        out.append(f"{law}: on a joint stop in {on_stop} of {r['episodes']} episodes, up to {r['stop_time_max']:.2f} s")
    rms, hold = med("rms_error"), med("hold_error")
    if r.get("segments", 0) >= 2 and np.isfinite(rms) and np.isfinite(hold) and hold < 0.5 * rms:
        out.append(f"{law}: its RMS error {rms:.1f} deg counts the reference's steps; after each step's transient it "
                   f"tracks to {hold:.1f} deg RMS (hold error)")
    return out


def shared_failures(metrics: Mapping[str, Mapping[str, np.ndarray]]) -> dict[str, Any] | None:
    """The episodes every law failed, from the laws' per-episode ``success`` (and ``airspeed``, m/s) of one paired
    batch (:class:`controllers.evaluation.evaluate.EvalResult.metrics`): ``{"laws", "episodes", "airspeed_m_s"}``
    (episode indices from 0, in the comparison's order), or None with fewer than two laws or no such episode."""
    if len(metrics) < 2:
        return None
    ok = np.array([np.asarray(m["success"], dtype=bool) for m in metrics.values()])
    idx = np.flatnonzero(~ok.any(axis=0))
    if idx.size == 0:
        return None
    first = next(iter(metrics.values()))
    v = np.asarray(first["airspeed"], dtype=np.float64)[idx] if "airspeed" in first else np.full(idx.size, np.nan)
    return {"laws": list(metrics), "episodes": idx.tolist(), "airspeed_m_s": [round(float(x), 3) for x in v]}


def _shared_caveat(shared: Mapping[str, Any], n: int) -> str:
    eps, v = shared["episodes"], np.asarray(shared["airspeed_m_s"], dtype=np.float64)
    shown = ", ".join(str(e) for e in eps[:12]) + (", ..." if len(eps) > 12 else "")
    speeds = f" at {np.nanmin(v):.1f}-{np.nanmax(v):.1f} m/s" if np.isfinite(v).any() else ""
    return (f"{len(eps)} of {n} episodes failed by every law ({', '.join(shared['laws'])}){speeds} (episodes {shown}): the same draws "
            "defeat every law, which points at the rig's reach or the task rather than at one law")


def recommend(rows: Mapping[str, Mapping[str, Any]], rule: ScoreRule = DEFAULT_RULE, shared: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The recommendation for one task and mode from its laws' rows (law -> row with ``success``,
    ``success_ci95``, ``episodes``, ``score``, ``score_ci95``, ``metrics``); see the module docstring.
    ``shared``: :func:`shared_failures` of the same batch (None: none, or not known).

    Returns ``{"law", "score", "score_ci95", "tied", "criterion", "ranking", "caveats", "shared_failures"}``."""
    ranking = sorted(rows, key=lambda k: (rows[k]["success"] >= rule.min_success, rows[k]["score"], rows[k]["success"]), reverse=True)
    eligible = [k for k in ranking if rows[k]["success"] >= rule.min_success]
    rec: dict[str, Any] = {"law": None, "score": None, "score_ci95": None, "tied": [], "criterion": f"success >= {_pct(rule.min_success)} %",
                           "ranking": [{"law": k, "success": rows[k]["success"], "score": rows[k]["score"], "score_ci95": list(rows[k]["score_ci95"]),
                                        "eligible": rows[k]["success"] >= rule.min_success} for k in ranking],
                           "caveats": [], "shared_failures": dict(shared) if shared else None}
    caveats: list[str] = rec["caveats"]
    if not rows:
        caveats.append("no law flew this task")
        return rec
    if not eligible:
        best = max(rows, key=lambda k: (rows[k]["success"], rows[k]["score"]))
        lo, hi = rows[best]["success_ci95"]
        caveats.append(f"no law meets the criterion (success >= {_pct(rule.min_success)} %): the best, {best}, succeeds in "
                       f"{_pct(rows[best]['success'])} % [{_pct(lo)}, {_pct(hi)}] of {rows[best]['episodes']} episodes")
        caveats += _caveats(best, rows[best], rule)
    else:
        top = eligible[0]
        t_lo, t_hi = rows[top]["score_ci95"]
        tied = [k for k in eligible if k == top or _overlap(rows[k]["score_ci95"], (t_lo, t_hi))]
        rec["score"], rec["score_ci95"] = rows[top]["score"], [t_lo, t_hi]
        if len(tied) > 1:
            rec["tied"] = tied
            caveats.append("tie: " + ", ".join(f"{k} {rows[k]['score']:.2f} [{rows[k]['score_ci95'][0]:.2f}, {rows[k]['score_ci95'][1]:.2f}]"
                                               for k in tied) + ": their 95 % score intervals overlap; more episodes may separate them")
            for k in tied:
                caveats += _caveats(k, rows[k], rule)
        else:
            rec["law"] = top
            caveats += _caveats(top, rows[top], rule)
    if shared:
        caveats.append(_shared_caveat(shared, max(int(r["episodes"]) for r in rows.values())))
    return rec


def _overlap(a: Sequence[float], b: Sequence[float]) -> bool:
    if not all(math.isfinite(x) for x in (*a, *b)):
        return True  # an undefined interval separates nothing
    return a[0] <= b[1] and b[0] <= a[1]


__all__ = ["DEFAULT_RULE", "ScoreRule", "episode_scores", "law_score", "recommend"]
