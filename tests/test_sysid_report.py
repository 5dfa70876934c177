"""Identification results people read and parameters that go back into the model.

Residual whiteness against theory (white Gaussian noise, an AR(1) process), the identified parameter
file (validation, a complete round trip, provenance), the report of a hand-built Fit, ``rig identify``
(configuration checks, outputs; the fit itself stubbed until ``rig_env.sysid.fit`` lands) and an
identified file flying in simulate(), the environments, the laws' design and ``rig compare``.
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import rig_env
import rig_env.sysid as sysid
from rig_env.params import DEFAULT_FILE, PARAM_NAMES, ParameterError, RigParams
from rig_env.sysid.diagnostics import autocorrelation, fit_measures, whiteness
from rig_env.sysid.paramfile import save_fit_params, write_params
from rig_env.sysid.records import FlightRecord
from rig_env.sysid.report import write_report
from rig_env.sysid.result import Fit


# ---------------------------------------------------------------------- diagnostics against theory
def test_white_noise_is_white_by_every_measure():
    rng = np.random.default_rng(7)
    n, lag, trials = 400, 20, 300
    frac, pvals = [], []
    for _ in range(trials):
        (w,) = whiteness(rng.standard_normal((n, 1)), ["e"], max_lag=lag)
        frac.append(w.fraction_outside)
        pvals.append(w.p_value)
        assert w.band == pytest.approx(1.96 / math.sqrt(n), rel=1e-3)
    # about 5 % of lags outside the 95 % band: the mean over 6000 lags has a standard error of 0.3 %
    assert abs(np.mean(frac) - 0.05) < 0.012
    # Ljung-Box p-values uniform on [0, 1] under the null
    assert stats.kstest(pvals, "uniform").pvalue > 0.01
    assert 0.02 < np.mean(np.asarray(pvals) < 0.05) < 0.09


def test_ar1_residual_is_strongly_coloured():
    rng = np.random.default_rng(3)
    n, rho = 2000, 0.8
    e = np.zeros(n)
    w = rng.standard_normal(n)
    for k in range(1, n):
        e[k] = rho * e[k - 1] + w[k]
    r = autocorrelation(e, 5)[:, 0]
    np.testing.assert_allclose(r, rho ** np.arange(6), atol=0.07)  # AR(1): r_k = rho^k
    (res,) = whiteness(e, ["e"], max_lag=20)
    assert res.p_value < 1e-12 and not res.is_white()
    assert res.fraction_outside > 0.4


def test_fit_measures_limits():
    t = np.linspace(0.0, 2.0, 401)[:-1]
    y = np.sin(2 * np.pi * t)[:, None]  # whole periods: mean 0
    perfect = fit_measures(y, np.zeros_like(y))[0]
    assert perfect.r2 == pytest.approx(1.0) and perfect.theil_u == pytest.approx(0.0) and perfect.rms == 0.0
    none = fit_measures(np.zeros_like(y), y)[0]  # predicts nothing: R^2 = 0, U = 1
    assert none.r2 == pytest.approx(0.0, abs=1e-12) and none.theil_u == pytest.approx(1.0)
    half = fit_measures(0.5 * y, 0.5 * y)[0]  # rms(e) = rms(y) / 2: R^2 = 3/4, U = 0.5 / 1.5
    assert half.r2 == pytest.approx(0.75) and half.theil_u == pytest.approx(1 / 3) and half.nrms == pytest.approx(0.5)


# ---------------------------------------------------------------------- the parameter file
IDENT = {
    "hawk_aero.CMalpha": {"value": -0.5, "std": 0.012, "records": ["pitch_3211", "pitch_doublet"], "method": "output_error"},
    "hawk_aero.CMq": {"value": -5.25, "std": 0.31, "records": ["pitch_3211", "pitch_doublet"], "method": "output_error"},
    "friction.rig_roll.Fc": {"value": 0.0583, "std": 0.0011, "records": ["roll_drop_1"], "method": "output_error"},
    "servos.compensator.delay_s": {"value": 0.018, "std": 0.002, "records": ["servo_steps"], "method": "equation_error"},
}


def _leaf(p: RigParams, name: str):
    for part in name.split("."):
        p = getattr(p, part)
    return p


def test_identified_file_round_trips_every_field(tmp_path: Path, params: RigParams):
    path = write_params(params, tmp_path / "identified.toml", identified=IDENT)
    back = RigParams.from_toml(path)
    for name in PARAM_NAMES:
        want = IDENT[name]["value"] if name in IDENT else _leaf(params, name)
        assert _leaf(back, name) == want, name
        if name in IDENT:
            prov = back.provenance(name)
            assert prov["source"] == "identified"
            assert (prov["std"], prov["records"], prov["method"]) == tuple(IDENT[name][k] for k in ("std", "records", "method"))
            assert IDENT[name]["method"] in prov["note"] and IDENT[name]["records"][0] in prov["note"]
        else:
            assert back.source(name) == params.source(name), name
    assert back.high_incidence == params.high_incidence
    assert back.source("high_incidence") == params.source("high_incidence")
    # a second generation: the identified file as the base keeps the first identification's provenance
    again = write_params(back, tmp_path / "second.toml", identified={"hawk_aero.CM0": {"value": 0.04, "std": 0.003, "records": ["r2"], "method": "filter_error"}})
    third = RigParams.from_toml(again)
    assert third.provenance("hawk_aero.CMq")["std"] == 0.31 and third.provenance("hawk_aero.CM0")["method"] == "filter_error"


def test_write_params_refuses_to_overwrite_and_unsourced_values(tmp_path: Path, params: RigParams):
    path = tmp_path / "p.toml"
    path.write_text("keep me")
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_params(params, path, identified=IDENT)
    assert path.read_text() == "keep me"
    write_params(params, path, identified=IDENT, overwrite=True)
    assert RigParams.from_toml(path).hawk_aero.CMq == -5.25
    with pytest.raises(ParameterError, match="mass.hawk_mass has no recorded source"):
        write_params(params.replace(**{"mass.hawk_mass": 1.3}), tmp_path / "q.toml")
    with pytest.raises(ParameterError, match="unknown parameter"):
        write_params(params, tmp_path / "r.toml", identified={"hawk_aero.nope": IDENT["hawk_aero.CMq"]})
    assert not (tmp_path / "q.toml").exists() and not (tmp_path / "r.toml").exists()


@pytest.mark.parametrize("entry, match", [
    ('{ value = -0.5, source = "identified", records = ["a"], method = "output_error" }', r"needs \['std'\]"),
    ('{ value = -0.5, source = "identified", std = -0.1, records = ["a"], method = "output_error" }', "std = -0.1: must be a finite number >= 0"),
    ('{ value = -0.5, source = "identified", std = 0.1, records = "a", method = "output_error" }', "records = 'a': must be a non-empty list"),
    ('{ value = -0.5, source = "identified", std = 0.1, records = ["a"], method = "" }', "method = '': must be a non-empty string"),
    ('{ value = -0.5, source = "paper", std = 0.1, note = "Table 3" }', r"\['std'\] belong to source = \"identified\" only"),
    ('{ value = -0.5, source = "identified", std = 0.1, records = ["a"], method = "oe", sigma = 1 }', r"unknown key\(s\) \['sigma'\]"),
])
def test_identified_entries_are_validated(tmp_path: Path, entry: str, match: str):
    text = DEFAULT_FILE.read_text()
    old = 'CMalpha = { value = -0.52, source = "paper", note = "Table 3" }'
    assert old in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(old, f"CMalpha = {entry}"))
    with pytest.raises(ParameterError, match="hawk_aero.CMalpha"):
        RigParams.from_toml(bad)
    with pytest.raises(ParameterError, match=match):
        RigParams.from_toml(bad)


# ---------------------------------------------------------------------- a hand-built fit
ESTIMATE = ("hawk_aero.CM0", "hawk_aero.CMalpha", "hawk_aero.CMq", "hawk_aero.CMde", "comp_aero.CLalpha", "friction.model_pitch.Fc")
VALUES = (0.0412, -0.5183, -4.127, -1.287, 6.43, 0.00183)
INITIAL = (0.037, -0.52, -4.36, -1.31, 6.61, 0.00189)
STD = (0.0021, 0.0125, 0.215, 0.0436, 0.118, 0.000105)
STD_WHITE = (0.0011, 0.0061, 0.102, 0.0213, 0.0587, 0.0000512)
TRUTH = {"hawk_aero.CMalpha": -0.52, "hawk_aero.CMq": -4.36, "comp_aero.CLalpha": 6.61}
NOISE = (math.radians(0.05), math.radians(0.8))  # rad, rad/s


def _record(name: str, n: int, rng: np.random.Generator) -> tuple[FlightRecord, np.ndarray, np.ndarray]:
    t = np.arange(n) / 100.0
    pitch = math.radians(4.0) * np.sin(2 * np.pi * 1.2 * t) * np.exp(-0.2 * t)
    rate = np.gradient(pitch, t)
    pred = np.column_stack([pitch, rate])
    res = rng.standard_normal((n, 2)) * NOISE
    rec = FlightRecord(t=t, free_dofs=("model_pitch",), q=pitch + res[:, 0], qd=rate + res[:, 1], airspeed=20.0, name=name)
    return rec, pred, res


def make_fit(params: RigParams, method: str = "output_error") -> Fit:
    rng = np.random.default_rng(11)
    recs = [_record("pitch_3211", 1200, rng), _record("pitch_doublet", 800, rng)]
    k = len(ESTIMATE)
    corr = np.eye(k)
    corr[1, 2] = corr[2, 1] = -0.95  # CMalpha-CMq: a pair the report must flag
    corr[0, 3] = corr[3, 0] = 0.42
    d = np.diag(STD)
    return Fit(
        method=method, estimate=ESTIMATE, values=dict(zip(ESTIMATE, VALUES)), initial=dict(zip(ESTIMATE, INITIAL)),
        std=dict(zip(ESTIMATE, STD)), std_white=dict(zip(ESTIMATE, STD_WHITE)), covariance=d @ corr @ d, correlation=corr,
        params=params.replace(**dict(zip(ESTIMATE, VALUES))), records=tuple(r for r, _, _ in recs),
        outputs=(("model_pitch", "model_pitch_rate"),) * 2, predicted=tuple(p for _, p, _ in recs), residuals=tuple(e for _, _, e in recs),
        noise_cov=np.diag(np.square(NOISE)), nuisance={"x0.pitch_3211.model_pitch": 0.0012},
        cost_history=(3.2e-2, 4.1e-3, 9.7e-4, 9.6e-4), iterations=3, converged=True, message="relative cost change < 1e-6",
    )


def _rows(md: str) -> dict[str, list[str]]:
    """Estimates rows by dotted name: the cells of each table row naming a parameter."""
    out = {}
    for line in md.splitlines():
        m = re.match(r"\| [^|]*\(`([\w.]+)`\) \|(.*)\|$", line)
        if m and m.group(1) not in out:
            out[m.group(1)] = [c.strip() for c in m.group(2).split("|")]
    return out


def test_report_of_a_hand_built_fit(tmp_path: Path, params: RigParams):
    fit = make_fit(params)
    path = write_report(fit, tmp_path, reference=TRUTH, title="Pitch fit")
    md = path.read_text()
    assert path == tmp_path / "report.md" and md.startswith("# Pitch fit")
    for png in ("correlation.png", "cost.png", "history_pitch_3211.png", "acf_pitch_3211.png", "history_pitch_doublet.png", "acf_pitch_doublet.png"):
        assert (tmp_path / png).stat().st_size > 5000, png
        assert f"]({png})" in md
    rows = _rows(md)
    assert list(rows) == list(ESTIMATE)
    # columns: unit, start, estimate, 95 % interval, sigma coloured, sigma white, relative %, reference, z
    cmq = rows["hawk_aero.CMq"]
    assert cmq[:3] == ["1/rad", "-4.36", "-4.127"]
    lo, hi = (float(x) for x in re.findall(r"-?[\d.]+(?:e-?\d+)?", cmq[3]))
    assert lo == pytest.approx(-4.127 - 1.96 * 0.215, rel=1e-3) and hi == pytest.approx(-4.127 + 1.96 * 0.215, rel=1e-3)
    assert cmq[4:6] == ["0.215", "0.102"]
    assert float(cmq[6]) == pytest.approx(100 * 0.215 / 4.127, rel=1e-2)
    assert cmq[7] == "-4.36" and float(cmq[8]) == pytest.approx((-4.127 + 4.36) / 0.215, rel=1e-2)
    assert rows["hawk_aero.CM0"][7:] == ["-", "-"]  # no reference given for it
    assert rows["friction.model_pitch.Fc"][0] == "N m" and rows["friction.model_pitch.Fc"][2] == "0.00183"
    assert "CMq + CMalphadot" in md
    # grouped by body, in the order the bodies first appear
    assert md.index("**Hawk model**") < md.index("**Compensator**") < md.index("**Friction, model pitch**")
    assert "`hawk_aero.CMalpha` and `hawk_aero.CMq`: r = -0.950" in md and "hawk_aero.CMde`: r" not in md
    # whiteness: one row per record and output; white residuals here, so p-values are not tiny
    white = [line for line in md.splitlines() if re.match(r"\| pitch_(3211|doublet) \| model_pitch", line)]
    assert len(white) == 4
    for line in white:
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[2] in ("1200", "800") and cells[3] == "25" and float(cells[6]) > 1e-4
    # noise estimate in deg and deg/s
    assert re.search(r"\| model_pitch \| 0\.05 \| deg \|", md) and re.search(r"\| model_pitch_rate \| 0\.8 \| deg/s \|", md)
    assert "3 iterations, converged" in md
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_report(fit, tmp_path)
    write_report(fit, tmp_path, overwrite=True)


def test_report_of_two_fits_side_by_side(tmp_path: Path, params: RigParams):
    one, two = make_fit(params), make_fit(params, "filter_error")
    md = write_report([one, two], tmp_path).read_text()
    assert "## Estimates side by side" in md and "fit 2 (filter error)" in md
    assert (tmp_path / "fit1_correlation.png").exists() and (tmp_path / "fit2_history_pitch_doublet.png").exists()
    assert "| CMq + CMalphadot (`hawk_aero.CMq`) | -4.127 +- 0.215 | -4.127 +- 0.215 |" in md


def _renamed(fit: Fit, *names: str) -> Fit:
    return dataclasses.replace(fit, records=tuple(dataclasses.replace(r, name=n) for r, n in zip(fit.records, names)))


@pytest.mark.parametrize("names, message", [
    (("run 1", "run_1"), r"records\[0\] 'run 1' and records\[1\] 'run_1': names of one file-name form 'run_1', so their report figures "
                         r"\(history_run_1.png, acf_run_1.png\) would collide; give each record its own name \(FlightRecord\(name=...\), "
                         r"FlightRecord.read\(..., name=...\) or dataclasses.replace\(record, name=...\); rig identify: the \[\[record\]\] table's name"),
    (("run", "run"), r"records\[0\] 'run' and records\[1\] 'run': the same name, so their report figures \(history_run.png, acf_run.png\) would collide"),
])
def test_report_refuses_records_whose_figures_would_be_one_file(tmp_path: Path, params: RigParams, names, message):
    """Records named "run 1" and "run_1" (or twice "run") both wrote history_run_1.png and acf_run_1.png: the first
    record's figures were lost and report.md showed the second's twice.  Refused before anything is written, naming
    both records and the figures; with several fits, each fit's figures carry their own prefix."""
    fit = _renamed(make_fit(params), *names)
    with pytest.raises(sysid.RecordError, match=message):
        write_report(fit, tmp_path / "out")
    with pytest.raises(sysid.RecordError, match=r"fit2_history_run"):
        write_report([make_fit(params), fit], tmp_path / "out")
    assert not (tmp_path / "out").exists()
    write_report([_renamed(make_fit(params), "run", "other"), _renamed(make_fit(params), "run", "other")], tmp_path / "two")  # fit by fit


def test_report_refuses_unknown_reference_names(tmp_path: Path, params: RigParams):
    """A misspelt reference name was dropped without a word (its row showed "-")."""
    fit = make_fit(params)
    with pytest.raises(ValueError, match=r"reference: unknown parameter 'hawk_aero.CMqq' \(did you mean 'hawk_aero.CMq'.*\?\); valid names: "
                                         r"rig_env.PARAM_NAMES"):
        write_report(fit, tmp_path / "out", reference={**TRUTH, "hawk_aero.CMqq": 1.0})
    with pytest.raises(ValueError, match=r"reference\['hawk_aero.CMq'\] = 'x': must be a number"):
        write_report(fit, tmp_path / "out", reference={"hawk_aero.CMq": "x"})
    assert not (tmp_path / "out").exists()
    md = write_report(fit, tmp_path / "ok", reference={"hawk_aero.CMq": np.float64(-4.36), "mass.hawk_mass": 1.0}).read_text()
    assert _rows(md)["hawk_aero.CMq"][7] == "-4.36"  # a name not estimated is known, just not shown


def test_save_fit_params_tags_the_estimates(tmp_path: Path, params: RigParams):
    fit = make_fit(params)
    back = RigParams.from_toml(save_fit_params(fit, tmp_path / "identified.toml"))
    assert back == fit.params
    for name, v, s in zip(ESTIMATE, VALUES, STD):
        prov = back.provenance(name)
        assert _leaf(back, name) == v and prov["std"] == s
        assert prov["records"] == ["pitch_3211", "pitch_doublet"] and prov["method"] == "output_error"
    assert back.source("mass.hawk_mass") == params.source("mass.hawk_mass")


# ---------------------------------------------------------------------- an identified file flies
@pytest.fixture
def identified_file(tmp_path: Path, params: RigParams) -> Path:
    return save_fit_params(make_fit(params), tmp_path / "identified.toml")


def test_identified_file_flies_in_simulate(identified_file: Path, params: RigParams):
    p = RigParams.from_toml(identified_file)
    kw = dict(free_dofs=["model_pitch"], controls={"hawk_elevator": 2.0}, airspeed=20.0)
    a = rig_env.simulate(p, [0.0], [0.0], 0.5, **kw)
    b = rig_env.simulate(params, [0.0], [0.0], 0.5, **kw)
    assert np.all(np.isfinite(a.q)) and not np.allclose(a.q, b.q)  # the identified CM0, CMalpha, CMq... act


def test_identified_file_flies_in_the_environments_and_the_design(identified_file: Path):
    from controllers import LoopSpec
    from controllers.design.model import design_model
    from rig_env.envs import RigVectorEnv

    p = RigParams.from_toml(identified_file)
    env = RigVectorEnv(1, task="pull_up_push_over", params_file=str(identified_file))
    assert env.params == p and env.params.hawk_aero.CMq == -4.127
    env.reset(seed=0)
    obs, *_ = env.step(np.zeros((1, env.single_action_space.shape[0])))
    assert np.all(np.isfinite(obs))
    spec = LoopSpec.from_env(env)
    d, d0 = design_model(p, spec.free_dofs, 20.0, 0.0), design_model(RigParams.default(), spec.free_dofs, 20.0, 0.0)
    assert not np.allclose(d.sys.A, d0.sys.A)


def test_compare_designs_and_flies_the_params_file(identified_file: Path, monkeypatch: pytest.MonkeyPatch):
    import io

    from controllers.evaluation import compare as cmp

    built, flown = [], []

    def fake_make(kind, spec, n, **options):
        built.append((kind, options.get("params")))
        raise cmp.UnsupportedTask("stub")  # plumbing only: nothing to evaluate

    monkeypatch.setattr(cmp, "make_controller", fake_make)
    envs = []
    real_env = cmp.RigVectorEnv
    monkeypatch.setattr(cmp, "RigVectorEnv", lambda *a, **kw: envs.append(kw) or real_env(*a, **kw))
    made = []  # the comparison's record, kept: with every law stubbed out compare ends in "no law could fly"
    real_comparison = cmp.Comparison
    monkeypatch.setattr(cmp, "Comparison", lambda *a, **kw: made.append(real_comparison(*a, **kw)) or made[-1])
    with pytest.raises(ValueError, match="no law could fly pull_up_push_over"):
        cmp.compare(tasks=["pull_up_push_over"], kinds=["lqr", "ppo"], episodes=1, modes=["robust"], out_dir=None, stream=io.StringIO(),
                    progress=False, params_file=identified_file)
    c = made[0]
    p = RigParams.from_toml(identified_file)
    assert [k for k, _ in built] == ["lqr", "ppo"]
    assert built[0][1] == p and built[1][1] is None  # designed on the file; the trained law is flown as trained
    assert envs[0]["params_file"] == str(identified_file)
    lo, hi = c.settings["conditions"]["robust"]["randomise"]["hawk_aero.CMq"]
    assert (lo + hi) / 2 == pytest.approx(-4.127)  # the spreads are centred on the identified values
    assert c.settings["params_file"] == str(identified_file) and "--params" in c.settings["command"]
    # the evaluation's environments get the file too
    got = {}

    class Evaluated(Exception):
        pass

    def fake_evaluate(laws, task, **kw):
        got.update(kw)
        raise Evaluated

    monkeypatch.setattr(cmp, "evaluate", fake_evaluate)
    monkeypatch.setattr(cmp, "make_controller", lambda kind, spec, n, **o: object())
    with pytest.raises(Evaluated):
        cmp.compare(tasks=["pull_up_push_over"], kinds=["lqr"], episodes=1, modes=["nominal"], out_dir=None, stream=io.StringIO(),
                    progress=False, params_file=identified_file)
    assert got["env_overrides"] == {"params_file": str(identified_file)}


def test_conditions_centred_on_the_default_rig_are_the_modes(params: RigParams):
    from controllers.design.conditions import MODES, modes_for

    assert modes_for(None) == MODES == modes_for(params)
    moved = modes_for(params.replace(**{"mass.hawk_mass": 1.5}))["nominal"].randomise["mass.hawk_mass"]
    assert moved == pytest.approx((1.35, 1.65))  # +-10 % about the given rig's Hawk mass


def test_rig_compare_params_errors(tmp_path: Path, capsys: pytest.CaptureFixture):
    from rig_cli.main import main

    assert main(["compare", "--params", str(tmp_path / "none.toml"), "--tasks", "pull_up_push_over"]) == 2
    assert "parameter file not found" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text("[environment]\n")
    assert main(["compare", "--params", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig compare: error:") and err.count("\n") == 1


# ---------------------------------------------------------------------- rig identify
CONFIG = """\
method = "output_error"
estimate = ["hawk_aero.CM0", { name = "hawk_aero.CMq", start = -4.0, bounds = [-30.0, 0.0] }]

[options]
max_iter = 7
tol = 1e-5

[[record]]
path = "pitch.csv"
name = "pitch_3211"
free_dofs = ["model_pitch"]
airspeed = 20.0
columns = { t = ["time_s", "s"], "q.model_pitch" = ["pitch", "rad"] }
segment = [0.5, 9.0]
"""


@pytest.fixture
def config(tmp_path: Path) -> Path:
    (tmp_path / "pitch.csv").write_text("time_s,pitch_rad\n0,0\n")
    path = tmp_path / "identify.toml"
    path.write_text(CONFIG)
    return path


def _stub(monkeypatch: pytest.MonkeyPatch, params: RigParams, converged: bool = True, warnings: tuple[str, ...] = ()) -> dict:
    """FlightRecord.read and sysid.fit stand-ins: what they were called with, and a hand-built Fit (with ``warnings``)."""
    calls: dict = {}
    rec = make_fit(params).records[0]

    def read(cls, path, **options):
        calls.setdefault("read", []).append((Path(path).name, options))
        return rec

    def fit(records, base, **kw):
        calls["fit"] = (records, base, kw)
        kw["progress"]("iteration 1: cost 4.1e-3")
        f = make_fit(params)
        return dataclasses.replace(f, converged=converged, warnings=warnings)

    monkeypatch.setattr(FlightRecord, "read", classmethod(read), raising=False)
    monkeypatch.setattr(FlightRecord, "segment", lambda self, t0, t1: calls.setdefault("segment", (t0, t1)) and self, raising=False)
    monkeypatch.setattr(sysid, "fit", fit, raising=False)
    return calls


def test_rig_identify_writes_report_and_params(config: Path, tmp_path: Path, params: RigParams, monkeypatch, capsys):
    from rig_cli.main import main

    calls = _stub(monkeypatch, params)
    out = tmp_path / "out"
    assert main(["identify", str(config), "--out", str(out)]) == 0
    io = capsys.readouterr()
    assert "iteration 1: cost 4.1e-3" in io.err and f"wrote {out / 'identified.toml'}" in io.out
    assert calls["read"] == [("pitch.csv", {"columns": {"t": ("time_s", "s"), "q.model_pitch": ("pitch", "rad")}, "free_dofs": ["model_pitch"], "airspeed": 20.0})]
    assert calls["segment"] == (0.5, 9.0)
    records, base, kw = calls["fit"]
    assert records[0].name == "pitch_3211" and base == params
    assert {k: v for k, v in kw.items() if k != "progress"} == {"estimate": ["hawk_aero.CM0", "hawk_aero.CMq"], "method": "output_error",
                                                                "bounds": {"hawk_aero.CMq": (-30.0, 0.0)}, "start": {"hawk_aero.CMq": -4.0},
                                                                "max_iter": 7, "tol": 1e-5}
    assert (out / "report.md").exists() and (out / "identify.toml").read_text() == CONFIG
    assert RigParams.from_toml(out / "identified.toml").provenance("hawk_aero.CMq")["std"] == 0.215
    # a second run refuses to overwrite, --overwrite replaces
    assert main(["identify", str(config), "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main(["identify", str(config), "--out", str(out), "--overwrite"]) == 0


def test_rig_identify_tells_the_fits_warnings_on_its_output_and_in_the_report(config: Path, tmp_path: Path, params: RigParams,
                                                                              monkeypatch, capsys):
    """A fit that carries warnings (sysid.misfit_warnings: an output the model does not follow) still writes its files,
    and rig identify prints each warning on a line of its own beside them, and the report lists them."""
    from rig_cli.main import main

    said = ("pitch: model_pitch is not followed (R^2 0.42 < 0.9, residuals far from white, Ljung-Box p 1e-300): a local minimum",)
    _stub(monkeypatch, params, warnings=said)
    out = tmp_path / "out"
    assert main(["identify", str(config), "--out", str(out)]) == 0
    assert f"warning: {said[0]}\n" in capsys.readouterr().out
    assert said[0] in (out / "report.md").read_text() and (out / "identified.toml").exists()


def test_rig_identify_unconverged_fit_writes_no_params(config: Path, tmp_path: Path, params: RigParams, monkeypatch, capsys):
    from rig_cli.main import main

    _stub(monkeypatch, params, converged=False)
    out = tmp_path / "out"
    assert main(["identify", str(config), "--out", str(out)]) == 2
    assert "did not converge" in capsys.readouterr().err
    assert (out / "report.md").exists() and not (out / "identified.toml").exists()


def test_rig_identify_refuses_to_replace_a_figure_before_the_fit(config: Path, tmp_path: Path, params: RigParams, monkeypatch, capsys):
    """The report's figures are outputs too: a file of a figure's name (known from the configuration and the records)
    is refused in one line, before the fit, naming it; --overwrite replaces it."""
    from rig_cli.main import main

    calls = _stub(monkeypatch, params)
    out = tmp_path / "out"
    out.mkdir()
    for name in ("cost.png", "acf_pitch_3211.png"):
        (out / name).write_text("mine\n")
    assert main(["identify", str(config), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig identify: error:") and err.count("\n") == 1 and "--overwrite" in err, err
    assert str(out / "cost.png") in err and str(out / "acf_pitch_3211.png") in err
    assert "fit" not in calls and sorted(p.name for p in out.iterdir()) == ["acf_pitch_3211.png", "cost.png"]
    assert (out / "cost.png").read_text() == "mine\n"
    assert main(["identify", str(config), "--out", str(out), "--overwrite"]) == 0
    assert (out / "cost.png").read_bytes().startswith(b"\x89PNG")


def test_rig_identify_refuses_a_figure_named_by_the_fit_before_writing_anything(config: Path, tmp_path: Path, params: RigParams,
                                                                                monkeypatch, capsys):
    """A figure only the fit names (its records: the stub's fit also holds pitch_doublet) is checked again after the
    fit, before any file is written; write_report itself refuses its figures too."""
    from rig_cli.main import main

    calls = _stub(monkeypatch, params)
    out = tmp_path / "out"
    out.mkdir()
    (out / "acf_pitch_doublet.png").write_text("mine\n")
    assert main(["identify", str(config), "--out", str(out)]) == 2
    err = capsys.readouterr().err.split("iteration 1: cost 4.1e-3\n")[-1]  # the fit's progress line, then the error
    assert err.startswith("rig identify: error:") and err.count("\n") == 1 and str(out / "acf_pitch_doublet.png") in err, err
    assert "fit" in calls and [p.name for p in out.iterdir()] == ["acf_pitch_doublet.png"]
    assert (out / "acf_pitch_doublet.png").read_text() == "mine\n"
    with pytest.raises(FileExistsError, match="acf_pitch_doublet.png"):
        write_report(make_fit(params), out)
    assert [p.name for p in out.iterdir()] == ["acf_pitch_doublet.png"]


def test_rig_identify_unconverged_overwrite_sets_the_earlier_params_aside(config: Path, tmp_path: Path, params: RigParams,
                                                                         monkeypatch, capsys):
    """--overwrite over an earlier successful run, with a fit that does not converge: the earlier identified.toml (another
    fit's) does not stay beside the new report; it is renamed identified.toml.stale, and the error line says so."""
    from rig_cli.main import main

    _stub(monkeypatch, params)
    out = tmp_path / "out"
    assert main(["identify", str(config), "--out", str(out)]) == 0
    earlier = (out / "identified.toml").read_text()
    capsys.readouterr()
    _stub(monkeypatch, params, converged=False)
    assert main(["identify", str(config), "--out", str(out), "--overwrite"]) == 2
    io = capsys.readouterr()
    err = io.err.split("iteration 1: cost 4.1e-3\n")[-1]  # the fit's progress line, then the error
    assert err.startswith("rig identify: error:") and err.count("\n") == 1 and "no parameter file written" in io.err and str(out / "identified.toml.stale") in err, err
    assert f"to {out / 'identified.toml.stale'}" in io.out
    assert not (out / "identified.toml").exists() and (out / "identified.toml.stale").read_text() == earlier
    assert "NOT converged" in (out / "report.md").read_text()


@pytest.mark.parametrize("sub", ["", "sub", "sub/deeper"])
def test_rig_identify_refuses_an_out_that_is_or_lies_under_a_file(config: Path, tmp_path: Path, params: RigParams, monkeypatch,
                                                                  capsys, sub):
    from rig_cli.main import main

    calls = _stub(monkeypatch, params)
    afile = tmp_path / "afile"
    afile.write_text("hi\n")
    dest = afile / sub if sub else afile
    assert main(["identify", str(config), "--out", str(dest)]) == 2
    err = capsys.readouterr().err
    what = "is a file" if not sub else f"lies under {afile}, a file"
    assert err == f"rig identify: error: --out {dest}: {what}, not a folder; give a folder\n", err
    assert "read" not in calls and "fit" not in calls and afile.read_text() == "hi\n"


@pytest.mark.parametrize("edit, match", [
    (("method = \"output_error\"", "method = \"least_squares\""), "method = 'least_squares': allowed: output_error, filter_error, equation_error"),
    (("\"hawk_aero.CM0\"", "\"hawk_aero.CMzz\""), r"estimate\[0\]: unknown parameter 'hawk_aero.CMzz'"),
    (("bounds = [-30.0, 0.0]", "bounds = [0.0, -30.0]"), r"estimate\[1\].bounds .* needs low < high"),
    (("start = -4.0", "start = 4.0"), r"estimate\[1\]: start = 4.0 is outside bounds"),
    (("tol = 1e-5", "tolerance = 1e-5"), r"options: unknown key\(s\) \['tolerance'\]; allowed: max_iter, tol"),
    (("max_iter = 7", "max_iter = 0"), "options.max_iter = 0: must be an integer >= 1"),
    (("max_iter = 7", "aero_model = \"quasi\""), "options.aero_model = 'quasi': allowed: linear, tables, unsteady"),
    (("path = \"pitch.csv\"", "path = \"missing.csv\""), r"record\[0\].path: file not found: .*missing.csv"),
    (("airspeed = 20.0", "speed = 20.0"), r"record\[0\]: unknown key\(s\) \['speed'\]; allowed: path, name, columns"),
    (("free_dofs = [\"model_pitch\"]", "free_dofs = [\"pitch\"]"), r"record\[0\].free_dofs = \['pitch'\]: must be a non-empty list of joints"),
    (("segment = [0.5, 9.0]", "segment = [0.5]"), r"record\[0\].segment = \[0.5\]: must be a pair"),
    (("method = \"output_error\"", "methods = \"output_error\""), r"unknown key\(s\) \['methods'\]; allowed: params, method, estimate"),
    (("method = \"output_error\"", "params = \"nowhere.toml\""), "params: file not found"),
])
def test_rig_identify_config_errors(config: Path, tmp_path: Path, params: RigParams, monkeypatch, capsys, edit, match):
    from rig_cli.main import main

    calls = _stub(monkeypatch, params)
    config.write_text(CONFIG.replace(*edit))
    assert main(["identify", str(config), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig identify: error:") and err.count("\n") == 1 and re.search(match, err), err
    assert "fit" not in calls and not (tmp_path / "out").exists()


def test_rig_identify_failed_fit_is_one_line(config: Path, tmp_path: Path, params: RigParams, monkeypatch, capsys):
    from rig_cli.main import main

    _stub(monkeypatch, params)

    def boom(*a, **k):
        raise np.linalg.LinAlgError("singular information matrix")

    monkeypatch.setattr(sysid, "fit", boom)
    assert main(["identify", str(config), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == "rig identify: error: the fit failed: singular information matrix\n"


def test_rig_identify_takes_the_aero_model_and_refuses_it_with_equation_error(config: Path, tmp_path: Path, params: RigParams,
                                                                              monkeypatch, capsys):
    """options.aero_model reaches sysid.fit; "unsteady" with equation error is a one-line error (no aerodynamic
    states in the measured ones)."""
    from rig_cli.identify import fit_kwargs, load_config
    from rig_cli.main import main

    config.write_text(CONFIG.replace("tol = 1e-5", "tol = 1e-5\naero_model = \"unsteady\""))
    assert fit_kwargs(load_config(config))["aero_model"] == "unsteady"
    calls = _stub(monkeypatch, params)
    config.write_text(CONFIG.replace("tol = 1e-5", "tol = 1e-5\naero_model = \"unsteady\"").replace('method = "output_error"', 'method = "equation_error"'))
    assert main(["identify", str(config), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "options.aero_model = 'unsteady' with method = 'equation_error'" in err and err.count("\n") == 1
    assert "fit" not in calls


@pytest.mark.parametrize(("extra", "n_samples", "message"), [
    ("", 2, "record[0]: pitch_3211 holds 2 sample(s) after segment and resample; a record to fit needs at least 10"),
    ("smooth = 5000\n", 1200, "record[0].smooth = 5000: more than the record's 1200 samples (after segment)"),
    ("locked = { rig_roll = 100.0 }\n", 1200, "record[0].locked.rig_roll = 100: a locked angle must lie within +-2 pi rad"),
])
def test_rig_identify_refuses_records_it_cannot_fit_before_the_fit(tmp_path: Path, params: RigParams, monkeypatch, capsys,
                                                                   extra, n_samples, message):
    """A 2-sample record failed only inside the fit, as "no effect on the records' outputs"; a smoothing span longer
    than the record was clipped to it (one local fit over the whole record); a locked angle of 100 (rad, taken
    for degrees) was flown.  Each is now refused in one line naming the key, before the fit."""
    from rig_cli.main import main

    calls = _stub(monkeypatch, params)
    rec = _record("pitch_3211", n_samples, np.random.default_rng(1))[0]
    monkeypatch.setattr(FlightRecord, "read", classmethod(lambda cls, path, **o: rec), raising=False)
    (tmp_path / "pitch.csv").write_text("time_s,pitch_rad\n0,0\n")
    (tmp_path / "identify.toml").write_text(CONFIG + extra)
    assert main(["identify", str(tmp_path / "identify.toml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"rig identify: error: {message}") and err.count("\n") == 1, err
    assert "fit" not in calls and not (tmp_path / "out").exists()


def test_rig_identify_overwrite_removes_the_earlier_runs_figures_it_does_not_write(config: Path, tmp_path: Path, params: RigParams,
                                                                                    monkeypatch, capsys):
    """An --overwrite run with a record fewer left the earlier run's figures of that record beside the new report,
    to be taken for this run's; they are removed now (the ones the earlier report.md showed), and nothing else."""
    from rig_cli.main import main

    _stub(monkeypatch, params)
    out = tmp_path / "out"
    assert main(["identify", str(config), "--out", str(out)]) == 0
    assert (out / "history_pitch_doublet.png").is_file() and (out / "acf_pitch_doublet.png").is_file()
    (out / "history_mine.png").write_text("mine\n")  # the user's, named like a figure but not the report's
    one = make_fit(params)
    one = dataclasses.replace(one, records=one.records[:1], outputs=one.outputs[:1], predicted=one.predicted[:1], residuals=one.residuals[:1])
    monkeypatch.setattr(sysid, "fit", lambda records, base, **kw: one, raising=False)
    assert main(["identify", str(config), "--out", str(out), "--overwrite"]) == 0
    said = capsys.readouterr().out
    assert "removed the earlier run's history_pitch_doublet.png, acf_pitch_doublet.png (not in this report)" in said
    assert not (out / "history_pitch_doublet.png").exists() and not (out / "acf_pitch_doublet.png").exists()
    assert (out / "history_pitch_3211.png").is_file() and (out / "history_mine.png").read_text() == "mine\n"
    assert "pitch_doublet" not in (out / "report.md").read_text()
