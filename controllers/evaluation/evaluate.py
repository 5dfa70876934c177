"""Run control laws on a task over seeded, randomised episodes, in parallel over one environment batch.

:func:`evaluate` builds one :class:`rig_env.envs.RigVectorEnv` holding ``n_episodes`` environments
per law (law ``c`` drives block ``c`` of the batch), resets it with one seed, steps every law on
its block until every environment has finished its first episode (same-step autoreset; later
episodes are ignored), and collects ``info["final_info"]`` metrics and the time histories of the
first ``record`` episodes of each block (true joint angles and rates, reference, actions).

Paired conditions: every block sees the same episodes (airspeed, references, parameter draws,
gusts, sensor noise), so the laws are compared on identical conditions: the batch is reset with
``options={"env_seeds": ...}`` giving environment ``i`` of every block the stream of seed ``s + i``.

Episodes are keyed by their index, never by their place in a batch: episode ``i`` of a comparison seeded
``s`` is the stream of seed ``s + i`` and every draw in it is a function of that stream alone
(:mod:`rig_env.envs.streams`), so ``evaluate(..., n_episodes=m, first_episode=i)`` runs exactly episodes
``i .. i + m - 1`` of the full run: the Ray backend's chunks (:mod:`controllers.evaluation.ray_backend`)
reproduce the local numbers.

Conditions (:class:`Conditions`; :data:`NOMINAL` and :data:`ROBUST`; defined in
:mod:`controllers.design.conditions`, where training finds them too):

| mode | airspeed | gusts | sensors | parameters drawn per episode, uniform |
|---|---|---|---|---|
| nominal | U(15, 25) m/s | 1 % of airspeed, 1 sigma, 0.2 s (the upper end of a low-speed tunnel's turbulence intensity) | env defaults: 0.05 deg noise, quantised, one period delay | Hawk mass +-10 %, servo delay 10-20 ms, servo bandwidth 5-8 Hz (the measured ranges of docs/PARAMETERS.md) |
| robust | same | same | same | nominal, plus +-20 % on every non-zero aerodynamic derivative (Hawk and compensator) and on the friction Fs, Fc, sigma2 of every joint |
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, TextIO

import numpy as np

from controllers import Controller, LoopSpec, make_controller
from controllers.evaluation.traces import trace_metrics
from controllers.design.conditions import GUSTY, MODES, NOMINAL, ROBUST, Conditions  # noqa: F401  (re-exported)
from rig_env.compile_watch import compile_watch
from rig_env.envs import TASKS, RigVectorEnv
from rig_env.envs.ranges import MAX_SEED
from rig_env.params import JOINTS




@dataclass
class EvalResult:
    """Metrics of ``n`` episodes per law and a few time histories.

    metrics[kind][name]: (n,) arrays (``rig_env.envs.metrics.METRIC_NAMES``, ``success``, ``status``,
    ``stop_exceeded``, the task's own; :data:`controllers.evaluation.traces.TRACE_NAMES` from every step's
    command and error; ``stop_time`` s, the constraint violations' steps times the control period;
    ``cmd_rms`` deg, the control effort times the surfaces' deflection per unit action;
    ``airspeed`` m/s, each episode's).  history[kind]: ``t`` (T,) s, ``q`` (k, T, 5) deg, ``qd`` (k, T, 5) deg/s,
    ``ref`` (k, T, m) task reference (angles deg, rates deg/s), ``action`` (k, T, n_a) normalised, ``y``,
    ``y_ref`` (k, T) the task's tracked quantity and its reference, deg (``Task.display``).  display: the
    task's ``label`` of that quantity, the ``joint`` (index in JOINTS) it is, if any, and ``rate`` (joint
    index, reference column) of a commanded rate, if any; ``actions``: the action names.
    """

    task: str
    conditions: str
    seed: int
    n_episodes: int
    paired: bool
    metrics: dict[str, dict[str, np.ndarray]]
    history: dict[str, dict[str, np.ndarray]]
    seconds: float
    build_seconds: dict[str, float]
    display: dict[str, Any] = field(default_factory=dict)


LawFactory = Callable[[LoopSpec, int], Controller]


def _progress(stream: TextIO | None, label: str, k: int, total: int, last: list[int]) -> None:
    if stream is None:
        return
    tty = bool(getattr(stream, "isatty", lambda: False)())
    pct = int(100 * k / total) // (2 if tty else 25) * (2 if tty else 25)
    if pct != last[0]:
        last[0] = pct
        if tty:
            stream.write(f"\r  {label:<56s} {pct:3d} %" + ("\n" if pct >= 100 else ""))
        else:
            stream.write(f"  {label:<56s} {pct:3d} %\n")
        stream.flush()


def evaluate(
    laws: Mapping[str, str | Controller | LawFactory],
    task: str,
    *,
    n_episodes: int = 40,
    seed: int = 0,
    conditions: Conditions | str = NOMINAL,
    record: int = 3,
    env_overrides: Mapping[str, Any] | None = None,
    progress: TextIO | None = None,
    first_episode: int = 0,
) -> EvalResult:
    """Run every law of ``laws`` on ``task`` over ``n_episodes`` episodes each, paired across laws.

    A law is given as a kind for :func:`make_controller`, a factory ``(spec, n) -> Controller``, or a
    built :class:`Controller` for ``n_episodes`` environments and this task's loop (it is reset here).
    ``conditions``: a :class:`Conditions` or a mode's name (:data:`MODES`: "nominal", "robust", "gusty");
    ``env_overrides``: further :class:`rig_env.envs.RigEnvConfig` fields; ``progress``: a stream for a
    progress display (None: silent); ``first_episode``: the index of the first episode run (episodes
    ``first_episode .. first_episode + n_episodes - 1`` of the comparison seeded ``seed``: a chunk of it).
    See the module docstring.
    """
    with compile_watch(progress):  # a fresh installation's first batch compiles its kernels: say so while it does
        return _evaluate(laws, task, n_episodes, seed, conditions, record, env_overrides, progress, first_episode)


def _evaluate(
    laws: Mapping[str, str | Controller | LawFactory],
    task: str,
    n_episodes: int,
    seed: int,
    conditions: Conditions | str,
    record: int,
    env_overrides: Mapping[str, Any] | None,
    progress: TextIO | None,
    first_episode: int = 0,
) -> EvalResult:
    if not isinstance(laws, Mapping):  # a list of kinds would fail later as "list indices must be integers"
        raise ValueError(f"laws = {laws!r}: must be a mapping name -> kind, Controller or factory, e.g. {{'pid': 'pid'}}")
    if not laws:
        raise ValueError("laws: give at least one law")
    if isinstance(conditions, str) and conditions in MODES:  # a mode's name, as compare's modes take them
        conditions = MODES[conditions]
    if not isinstance(conditions, Conditions):
        raise ValueError(f"conditions = {conditions!r}: must be a Conditions or a mode name from {sorted(MODES)}")
    if task not in TASKS:  # a KeyError from the registry would name nothing a caller can act on
        raise ValueError(f"task = {task!r}: unknown; valid names: {sorted(TASKS)}")
    if isinstance(n_episodes, bool) or not isinstance(n_episodes, int) or n_episodes < 1:  # True is an int, not a count
        raise ValueError(f"n_episodes = {n_episodes!r}: must be a positive integer")
    if isinstance(record, bool) or not isinstance(record, int) or record < 0:  # negative: numpy's "negative dimensions"
        raise ValueError(f"record = {record!r}: must be an integer >= 0 (episodes per law whose time histories are kept)")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed = {seed!r}: must be an integer in [0, {MAX_SEED}]")
    if isinstance(first_episode, bool) or not isinstance(first_episode, int) or first_episode < 0:
        raise ValueError(f"first_episode = {first_episode!r}: must be a non-negative integer")
    names = list(laws)
    n, C = n_episodes, len(names)
    fields = {**conditions.env_fields(task), **dict(env_overrides or {})}
    env = RigVectorEnv(n * C, task=task, **fields)
    spec = LoopSpec.from_env(env)
    built: dict[str, Controller] = {}
    build_s: dict[str, float] = {}
    for name in names:
        t0 = time.perf_counter()
        how = laws[name]
        if isinstance(how, Controller):
            if how.num_envs != n or how.spec != spec:
                raise ValueError(f"laws[{name!r}]: built for {how.num_envs} envs of task {how.spec.task!r}; need {n} of {task!r} with this loop")
            built[name] = how
        else:
            built[name] = make_controller(how, spec, n) if isinstance(how, str) else how(spec, n)
        build_s[name] = time.perf_counter() - t0
    t_start = time.perf_counter()
    # every block on the streams of its episodes' indices: seed + first_episode, ..., seed + first_episode + n - 1
    obs, _ = env.reset(options={"env_seeds": np.tile(seed + first_episode + np.arange(n), C)})
    paired = True
    for law in built.values():
        law.reset()
    blocks = {name: slice(c * n, (c + 1) * n) for c, name in enumerate(names)}
    k_rec = min(record, n)
    T = env.max_steps
    q_h = np.full((C, k_rec, T, 5), np.nan)  # NaN after an episode's end
    qd_h = np.full((C, k_rec, T, 5), np.nan)
    ref0 = env.reference()
    ref_h = np.full((C, k_rec, T, ref0.shape[1]), np.nan)
    act_h = np.full((C, k_rec, T, len(env.action_names)), np.nan)
    y_h, yr_h = np.full((C, k_rec, T), np.nan), np.full((C, k_rec, T), np.nan)
    # every environment's command, tracking error and segment until its first episode ends (traces.py)
    act_all = np.zeros((T, n * C, len(env.action_names)), dtype=np.float32)
    err_all, seg_all = np.zeros((T, n * C), dtype=np.float32), np.full((T, n * C), -1, dtype=np.int32)
    live_all = np.zeros((T, n * C), dtype=bool)
    airspeed = np.array(env.airspeed, dtype=float).copy()  # each episode's, drawn at the reset
    done = np.zeros(n * C, dtype=bool)
    rec_live = np.ones(n * C, dtype=bool)
    final: dict[str, np.ndarray] = {}
    actions = np.zeros((n * C, len(env.action_names)))
    last = [-1]
    label = f"{task} [{conditions.name}] {n} episodes x {C} laws"
    for step in range(T):
        for name, b in blocks.items():
            actions[b] = built[name].act(obs[b])
        obs, _, term, trunc, info = env.step(actions)
        ended = term | trunc
        rec_live &= ~ended  # an ended environment already holds its next episode (same-step autoreset)
        ref_rad = env.reference()
        y_disp, y_ref = env.task.display(env.t, env.joint_angles, env.joint_rates, ref_rad)
        seg_t, _, _, err_t, _ = env.task.tracked(env.t, env.joint_angles, env.joint_rates, ref_rad)
        live_all[step] = rec_live  # the ending step's state is already the next episode's (same-step autoreset)
        act_all[step], err_all[step], seg_all[step] = actions, err_t, seg_t
        q, qd, ref = np.degrees(env.joint_angles), np.degrees(env.joint_rates), np.degrees(ref_rad)
        for c, b in enumerate(blocks.values()):
            rows = np.arange(b.start, b.start + k_rec)
            live = rec_live[rows]
            q_h[c, live, step], qd_h[c, live, step] = q[rows][live], qd[rows][live]
            ref_h[c, live, step], act_h[c, live, step] = ref[rows][live], actions[rows][live]
            y_h[c, live, step], yr_h[c, live, step] = y_disp[rows][live], y_ref[rows][live]
        if "final_info" in info:
            fi, m = info["final_info"], info["_final_info"] & ~done
            for key, v in fi.items():
                if key.startswith("_"):
                    continue
                if key not in final:
                    final[key] = np.zeros(n * C, dtype=np.asarray(v).dtype)
                final[key][m] = np.asarray(v)[m]
        done |= ended
        for name, b in blocks.items():
            built[name].reset(ended[b])
        _progress(progress, label, step + 1, T, last)
        if np.all(done):
            break
    seconds = time.perf_counter() - t_start
    t = (np.arange(T) + 1) * env.dt
    traced = trace_metrics(act_all[: step + 1], err_all[: step + 1], seg_all[: step + 1], live_all[: step + 1], env.dt,
                           float(env.action_scale_deg))
    final.update(traced, airspeed=airspeed, stop_time=np.asarray(final["constraint_violations"], dtype=float) * env.dt,
                 cmd_rms=np.asarray(final["control_effort"], dtype=float) * float(env.action_scale_deg))
    metrics = {name: {k: v[b].copy() for k, v in final.items()} for name, b in blocks.items()}
    history = {name: {"t": t, "q": q_h[c], "qd": qd_h[c], "ref": ref_h[c], "action": act_h[c], "y": y_h[c], "y_ref": yr_h[c]}
               for c, name in enumerate(names)}
    rate = env.task.display_rate
    display = {"label": env.task.display_label, "joint": env.task.display_joint, "rate": rate, "actions": tuple(env.action_names),
               "rate_label": None if rate is None else f"{JOINTS[rate[0]].replace('_', ' ')} rate, deg/s"}
    return EvalResult(task, conditions.name, seed, n, paired, metrics, history, seconds, build_s, display)
