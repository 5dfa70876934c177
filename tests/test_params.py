"""Parameter file, provenance tags, validation and the kernel layout."""

import math
import os
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


# ---------------------------------------------------------------------- the file's units, tables, methods and the writer
def _default_with(tmp_path: Path, old: str, new: str, name: str = "edited.toml") -> Path:
    text = rig_env.params.DEFAULT_FILE.read_text()
    assert text.count(old) >= 1, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


LOWER = 'lower_deg = { value = -25.0, source = "estimate", unit = "deg"'  # the first: [stops.rig_pitch]


@pytest.mark.parametrize("unit", ['"rad"', '"pounds"', "5", '"DEG"'])
def test_a_unit_other_than_the_fields_own_is_refused_never_reinterpreted(tmp_path: Path, unit: str):
    path = _default_with(tmp_path, LOWER, LOWER.replace('unit = "deg"', f"unit = {unit}"))
    given = repr(unit.strip('"')) if unit.startswith('"') else unit
    with pytest.raises(ParameterError, match=rf"^{path}: stops.rig_pitch.lower_deg.unit = {given}, but stops.rig_pitch.lower_deg "
                                             rf"is in 'deg'; give the value in 'deg'.*not converted"):
        RigParams.from_toml(path)


def test_the_fields_own_unit_or_none_loads(tmp_path: Path, params):
    assert RigParams.from_toml(_default_with(tmp_path, LOWER, LOWER.replace(', unit = "deg"', ""))) == params
    assert RigParams.from_toml(_default_with(tmp_path, LOWER, LOWER, "same.toml")).stops.rig_pitch.lower_deg == -25.0


def test_replace_stores_tables_as_tuples_of_floats_and_numpy_numbers_as_numbers(params, tmp_path: Path):
    hi = params.high_incidence
    for given in (np.array(hi.hawk_CL), list(hi.hawk_CL), [np.float64(v) for v in hi.hawk_CL]):
        q = params.replace(**{"high_incidence.hawk_CL": given})
        assert type(q.high_incidence.hawk_CL) is tuple and all(type(v) is float for v in q.high_incidence.hawk_CL)
        assert q == params and hash(q) == hash(params)
    q = params.replace(**{"high_incidence.alpha_deg": [int(a) for a in hi.alpha_deg]})  # ints: floats in the table
    assert q.high_incidence.alpha_deg == hi.alpha_deg and all(type(v) is float for v in q.high_incidence.alpha_deg)
    RigParams.from_toml(params.replace(**{"high_incidence.hawk_CL": np.array(hi.hawk_CL)}).to_toml(tmp_path / "t.toml"))
    m = params.replace(**{"mass.hawk_mass": np.float32(1.25), "stops.rig_pitch.upper_deg": np.int64(20), "mass.arm_mass": np.array(2.4)})
    assert (m.mass.hawk_mass, m.stops.rig_pitch.upper_deg, m.mass.arm_mass) == (1.25, 20, 2.4)
    assert type(m.mass.hawk_mass) is float and type(m.stops.rig_pitch.upper_deg) is int
    assert params.with_lift_break(np.int64(6), np.float64(0.05)) == params.with_lift_break(6, 0.05)
    with pytest.raises(ParameterError, match="mass.hawk_mass must be a number, got np.True_|mass.hawk_mass must be a number, got True"):
        params.replace(**{"mass.hawk_mass": np.bool_(True)})


@pytest.mark.parametrize("name, value, match", [
    ("high_incidence.alpha_deg", 5.0, r"high_incidence.alpha_deg must be a list of numbers \(one per breakpoint\), got float 5.0"),
    ("high_incidence.alpha_deg", np.zeros((2, 18)), r"high_incidence.alpha_deg must be a flat list of numbers, got an array of shape \(2, 18\)"),
    ("high_incidence.hawk_CM", ["x"] * 18, r"high_incidence.hawk_CM\[0\] must be a number, got 'x'"),
    ("high_incidence.hawk_CM", [[0.1]] * 18, r"high_incidence.hawk_CM\[0\] must be a number, got a nested list"),
    ("high_incidence.hawk_CL", [0.1] * 17, r"high_incidence.hawk_CL: needs one value per breakpoint of high_incidence.alpha_deg \(18\), got 17"),
    ("high_incidence.comp_alpha_deg", [0.0], r"high_incidence.comp_alpha_deg: needs at least 2 breakpoints, got 1"),
])
def test_replace_refuses_bad_tables_by_field(params, name, value, match):
    with pytest.raises(ParameterError, match=match):
        params.replace(**{name: value})


ALPHA = "alpha_deg = [-30.0, -20.0,"
HAWK_CL = "hawk_CL = [-0.60, -0.55,"
COMP_CN = "comp_CN = [0.0, -1.0,"


@pytest.mark.parametrize("old, new, match", [
    (ALPHA, 'alpha_deg = ["x", -20.0,', r"high_incidence.alpha_deg\[0\] must be a number, got 'x'"),
    (ALPHA, "alpha_deg = [[-30.0], -20.0,", r"high_incidence.alpha_deg\[0\] must be a number, got a nested list"),
    ("alpha_deg = [-30.0, -20.0, -16.0, -12.0, -8.0, -4.0, 0.0, 4.0, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 30.0, 40.0, 60.0, 90.0]",
     "alpha_deg = 5.0", r"high_incidence.alpha_deg must be a list of numbers \(one per breakpoint\), got float 5.0"),
    (ALPHA, "alpha_deg = [nan, -20.0,", r"high_incidence.alpha_deg\[0\] must be finite, got nan"),
    (ALPHA, "alpha_deg = [-10.0, -20.0,", r"high_incidence.alpha_deg must be strictly increasing: \[0\] = -10.0 deg, then \[1\] = -20.0 deg"),
    (ALPHA, "alpha_deg = [-300.0, -20.0,", r"high_incidence.alpha_deg\[0\] = -300.0 deg is outside the allowed range \[-180.0, 180.0\] deg"),
    (HAWK_CL, "hawk_CL = [-1e6, -0.55,", r"high_incidence.hawk_CL\[0\] = -1000000.0 is outside the allowed range \[-5.0, 5.0\] \(\|CL\|"),
    (COMP_CN, "comp_CN = [0.0, inf,", r"high_incidence.comp_CN\[1\] must be finite, got inf"),
    (HAWK_CL, "hawk_CL = [-0.55,", r"high_incidence.hawk_CL: needs one value per breakpoint of high_incidence.alpha_deg \(18\), got 17"),
    ("hawk_mass = { value = 1.0,", "hawk_mass = { value = 100.0,", r"mass.hawk_mass = 100.0 kg is outside the allowed range \[0.1, 10.0\] kg"),
    ("hawk_Izz = { value = 0.021,", "hawk_Izz = { value = 0.5,", "mass.hawk_Izz = 0.5 violates the rigid-body triangle inequality"),
])
def test_file_errors_name_the_file_and_the_field(tmp_path: Path, old, new, match):
    path = _default_with(tmp_path, old, new)
    with pytest.raises(ParameterError, match=rf"^{path}: {match}"):
        RigParams.from_toml(path)


def test_a_folder_or_a_binary_file_is_refused_naming_it(tmp_path: Path):
    with pytest.raises(ParameterError, match=rf"^{tmp_path}: is a folder, not a parameter file$"):
        RigParams.from_toml(tmp_path)
    binary = tmp_path / "rig.toml"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    with pytest.raises(ParameterError, match=rf"^{binary}: not a parameter file \(not UTF-8 text: byte 0 is b'\\x89'\)$"):
        RigParams.from_toml(binary)


def test_identified_method_is_one_of_the_identification_methods(params, tmp_path: Path):
    from rig_env.params_io import IDENTIFICATION_METHODS
    from rig_env.sysid import METHODS
    from rig_env.sysid.paramfile import write_params

    assert IDENTIFICATION_METHODS is METHODS  # one list: the file format's is the identification's
    ident = {"mass.hawk_mass": {"value": 1.2, "std": 0.01, "records": ["r1"], "method": "filter_error"}}
    text = write_params(params, tmp_path / "fit.toml", identified=ident).read_text()
    assert RigParams.from_toml(tmp_path / "fit.toml").provenance("mass.hawk_mass")["method"] == "filter_error"
    typo = tmp_path / "typo.toml"
    typo.write_text(text.replace('method = "filter_error"', 'method = "outptu_error"'))
    with pytest.raises(ParameterError, match=rf"^{typo}: mass.hawk_mass.method = 'outptu_error'; allowed: output_error, filter_error, equation_error$"):
        RigParams.from_toml(typo)
    with pytest.raises(ParameterError, match=r"identified\['mass.hawk_mass'\].method = 'oe'; allowed: output_error"):
        write_params(params, tmp_path / "oe.toml", identified={"mass.hawk_mass": dict(ident["mass.hawk_mass"], method="oe")})
    assert not (tmp_path / "oe.toml").exists()


def test_writers_leave_other_files_alone_and_errors_name_the_destination(params, tmp_path: Path):
    """A user's ``<name>.tmp`` beside the destination is neither replaced nor removed; a file that does not load
    back is reported under the destination's name; nothing is left behind; the file's mode is a new file's."""
    from rig_env.sysid.paramfile import write_params

    mine = tmp_path / "user.toml.tmp"
    mine.write_text("my notes\n")
    params.to_toml(tmp_path / "user.toml")
    write_params(params, tmp_path / "user.toml", overwrite=True)
    assert mine.read_text() == "my notes\n"
    assert RigParams.from_toml(tmp_path / "user.toml") == params
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "user.toml").stat().st_mode & 0o777 == 0o666 & ~umask
    bad = tmp_path / "rep" / "w2.toml"
    with pytest.raises(ParameterError, match=rf"^{bad}: mass.hawk_mass.records = \[''\]: must be a non-empty list of record names"):
        write_params(params, bad, identified={"mass.hawk_mass": {"value": 1.2, "std": 0.01, "records": [""], "method": "output_error"}})
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["rep", "user.toml", "user.toml.tmp"]
    with pytest.raises(ParameterError, match=rf"^{tmp_path / 'rep'}: is a folder, not a parameter file$"):
        params.to_toml(tmp_path / "rep", overwrite=True)
