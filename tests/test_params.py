"""Parameter file, provenance tags, validation and the kernel layout."""

import math
from pathlib import Path

import numpy as np
import pytest

import rig_env
from rig_env.params import PARAM_INDEX, ParameterError, RigParams, param_batch
from rig_env.physics import layout as L


def test_layout_matches_param_names():
    for name, i in PARAM_INDEX.items():
        assert getattr(L, "P_" + name.replace(".", "_").upper()) == i
    assert L.N_PARAMS == len(rig_env.PARAM_NAMES)


def test_every_value_has_a_source(params):
    for name in rig_env.PARAM_NAMES:
        src, note = params.source(name)
        assert src in ("paper", "rig-code", "estimate")
        if src == "estimate":
            assert note


def test_paper_values_are_the_papers(params):
    # Table 2 (model-pitch friction) and Table 4 (compensator), copied from the paper text
    f = params.friction.model_pitch
    assert (f.Fs, f.Fc, f.alpha_f, f.v_d, f.sigma0, f.sigma1, f.sigma2) == (1.95e-3, 1.89e-3, 95.6, 0.10, 9.37, 4.88e-5, 4.33e-4)
    c = params.comp_aero
    assert (c.CLalpha, c.CLq, c.CLde, c.CD0, c.CMalpha, c.CMq, c.CMde) == (6.61, 75.34, 1.694, 0.043, -2.16, -26.74, -0.77)
    assert params.source("hawk_aero.CMalpha") == ("paper", "Table 3")


def test_degrees_become_radians_in_the_kernel_vector(params):
    v = params.to_vector()
    assert v[L.P_STOPS_MODEL_PITCH_UPPER_DEG] == pytest.approx(math.radians(params.stops.model_pitch.upper_deg))
    assert v[L.P_SERVOS_HAWK_RATE_LIMIT_DEG_S] == pytest.approx(math.radians(350.0))


def test_replace_and_batch_overrides(params):
    q = params.replace(**{"mass.hawk_mass": 1.3, "friction.rig_roll.Fc": 0.05})
    assert q.mass.hawk_mass == 1.3 and q.friction.rig_roll.Fc == 0.05
    assert params.mass.hawk_mass == 1.0  # frozen original untouched
    P = param_batch(params, 3, {"mass.hawk_mass": [0.9, 1.0, 1.1]})
    assert P.shape == (3, L.N_PARAMS)
    np.testing.assert_allclose(P[:, L.P_MASS_HAWK_MASS], [0.9, 1.0, 1.1])


@pytest.mark.parametrize(
    "name, value, match",
    [
        ("mass.hawk_mass", -1.0, r"mass.hawk_mass = -1.0 kg is outside the allowed range \[0.1, 10.0\]"),
        ("mass.hawk_Izz", 0.5, "triangle inequality"),
        ("friction.model_pitch.Fs", 1e-4, "must be >= friction.model_pitch.Fc"),
        ("friction.rig_roll.Fc", 0.0, r"friction.rig_roll.Fc = 0.0 N m is outside the allowed range \[1e-06, 10.0\]"),
        ("stops.rig_pitch.upper_deg", 95.0, "stops.rig_pitch.upper_deg"),
        ("hawk_aero.CLalpha", float("nan"), "must be finite"),
        ("no.such", 1.0, "unknown parameter"),
    ],
)
def test_invalid_values_name_field_and_range(params, name, value, match):
    with pytest.raises(ParameterError, match=match):
        params.replace(**{name: value})


def test_bad_files(tmp_path: Path):
    text = rig_env.params.DEFAULT_FILE.read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('arm_length = { value = 0.8, source = "rig-code"', 'arm_length = { value = 0.8, source = "guess"'))
    with pytest.raises(ParameterError, match="geometry.arm_length.source"):
        RigParams.from_toml(bad)
    bad.write_text(text + "\n[extra]\nx = 1\n")
    with pytest.raises(ParameterError, match="unknown field"):
        RigParams.from_toml(bad)
    bad.write_text(text.replace('note = "about 1.0 kg, range 0.8-1.5 kg (docs/PARAMETERS.md)"', 'note = ""'))
    with pytest.raises(ParameterError, match="mass.hawk_mass is an estimate and needs a 'note'"):
        RigParams.from_toml(bad)
    with pytest.raises(ParameterError, match="not found"):
        RigParams.from_toml(tmp_path / "missing.toml")


def test_batch_override_errors(params):
    with pytest.raises(ParameterError, match="n_envs = 3"):
        param_batch(params, 3, {"mass.hawk_mass": [1.0, 1.1]})
    with pytest.raises(ParameterError, match="unknown parameter"):
        param_batch(params, 3, {"mass.nope": 1.0})
    with pytest.raises(ParameterError, match="outside the allowed range"):
        param_batch(params, 2, {"mass.hawk_mass": [1.0, 100.0]})


def test_static_balance_and_roll_imbalance():
    """The paper's model: Sec. I, the compensator balances the pendulum in pitch; a small roll imbalance remains
    (Sec. VI), below the later rig's measured value."""
    params = RigParams.paper()
    g, m = params.geometry, params.mass
    pitch_moment = m.hawk_mass * (g.arm_length + g.hawk_cg_x) + m.arm_mass * g.arm_cg_x + m.comp_mass * g.comp_cg_x
    roll_moment = m.hawk_mass * g.hawk_cg_z + m.arm_mass * g.arm_cg_z + m.comp_mass * g.comp_cg_z
    assert abs(pitch_moment) < 0.02  # kg m
    assert 0.05 < roll_moment < 0.398  # below the rig-code no-model value


def test_consistent_set_balance_roll_imbalance_and_compensator_axis():
    """The consistent set, the default rig: pitch balanced; the rig's roll imbalance without the model is the later rig's
    measured 0.398 kg m (rig-code); the compensator on the arm axis with its force at its c.g. (eq. 17)."""
    params = RigParams.consistent()
    assert params == RigParams.default()
    g, m = params.geometry, params.mass
    pitch_moment = m.hawk_mass * (g.arm_length + g.hawk_cg_x) + m.arm_mass * g.arm_cg_x + m.comp_mass * g.comp_cg_x
    rig_roll_moment = m.arm_mass * g.arm_cg_z + m.comp_mass * g.comp_cg_z  # without the model
    assert abs(pitch_moment) < 0.02  # kg m
    assert rig_roll_moment == pytest.approx(0.398, abs=0.001)  # the later rig's measured value (rig-code)
    # the compensator on the arm axis (eq. 17), its aerodynamic force at its c.g. (Sec. V)
    assert (g.comp_cg_y, g.comp_cg_z) == (0.0, 0.0) and g.comp_aero_x == g.comp_cg_x


def test_to_toml_round_trip_values_sources_and_identified(params, tmp_path: Path):
    """A complete file: from_toml reads back the same values, sources and identified entries; a replaced value
    is written with the default file's source only when it is the default's value."""
    from rig_env.sysid.paramfile import write_params

    ident = {"mass.hawk_mass": {"value": 1.2, "std": 0.01, "records": ["r1"], "method": "output_error"}}
    fitted = RigParams.from_toml(write_params(params, tmp_path / "fit.toml", identified=ident))
    back = RigParams.from_toml(fitted.to_toml(tmp_path / "again.toml"))
    assert back == fitted and back.sources == fitted.sources and back.identified == fitted.identified
    assert back.provenance("mass.hawk_mass")["std"] == 0.01 and back.source("mass.hawk_mass")[0] == "identified"
    body = [ln for ln in (tmp_path / "again.toml").read_text().splitlines() if not ln.startswith("#")]
    assert sum(ln.count("source =") for ln in body) == len(fitted.sources)  # every value carries its own
    default = RigParams.from_toml(params.to_toml(tmp_path / "default.toml"))
    assert default == params and default.sources == params.sources
    with pytest.raises(FileExistsError, match="overwrite"):
        params.to_toml(tmp_path / "default.toml")
    params.to_toml(tmp_path / "default.toml", overwrite=True)
    with pytest.raises(ParameterError, match="hawk_mass has no recorded source"):
        params.replace(**{"mass.hawk_mass": 1.3}).to_toml(tmp_path / "unsourced.toml")
    assert not (tmp_path / "unsourced.toml").exists()


def test_file_without_the_issue21_parameters_keeps_its_model(tmp_path):
    """A parameter file written before the alpha-dot split, tail blanking and Clbeta(CL) loads with the
    documented neutral values (params.NEUTRAL_DEFAULTS), which switch those terms off."""
    from rig_env.params import CONSISTENT_FILE, NEUTRAL_DEFAULTS

    text = CONSISTENT_FILE.read_text()  # the set where the new terms are on
    kept = [ln for ln in text.splitlines() if not ln.startswith(tuple(n.split(".")[1] + " =" for n in NEUTRAL_DEFAULTS))]
    assert len(kept) == len(text.splitlines()) - len(NEUTRAL_DEFAULTS)
    old = tmp_path / "old.toml"
    old.write_text("\n".join(kept) + "\n")
    p = RigParams.from_toml(old)
    a = p.hawk_aero
    assert (a.alphadot_fraction, a.blanked_fraction, a.Clbeta_CL) == (0.0, 1.0, 0.0)
    assert p.source("hawk_aero.alphadot_fraction")[0] == "estimate"
    # everything else as in the file
    d = RigParams.consistent()
    assert p.replace(**{n: getattr(d.hawk_aero, n.split(".")[1]) for n in NEUTRAL_DEFAULTS}) == d
