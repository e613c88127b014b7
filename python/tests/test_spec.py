"""Spec parsing and validation, grid and random designs, variant hashes (no osiris binary)."""

import copy
import tomllib

import pytest

from osiris_sweep.spec import (
    SpecError,
    design_points,
    load_spec,
    parse_spec,
    resolve_variants,
    variant_hash,
)

from .conftest import REPO


def spec_of(text: str):
    return parse_spec(tomllib.loads(text))


def variants_of(text: str, base, names=None):
    return resolve_variants(spec_of(text), base, names)


GRID = """
[sweep]
sensors = ["radar"]
[scenario]
set = { duration_s = 0.5 }
[parameters]
"scenario.road_users.0.x_m" = [70.0, 110.0]
"scenario.environment.rain_mm_h" = [0.0, 4.0, 16.0]
"config.seed" = [1, 2]
"""


def test_example_spec(base_scenario):
    spec = load_spec(REPO / "examples/sweep/small.toml")
    assert (spec.name, spec.sensors, spec.design) == ("small", ["radar"], "grid")
    vs = resolve_variants(spec, base_scenario, {"radar": {"range_m", "mode", "config"}})
    assert len(vs) == 8
    assert all(v.scenario["duration_s"] == 0.5 for v in vs)
    assert len({v.hash for v in vs}) == 8


def test_grid_count_order_and_values(base_scenario):
    vs = variants_of(GRID, base_scenario)
    assert len(vs) == 2 * 3 * 2
    # last key fastest
    assert [v.params["config.seed"] for v in vs[:4]] == [1, 2, 1, 2]
    assert [v.params["scenario.environment.rain_mm_h"] for v in vs[:4]] == [0.0, 0.0, 4.0, 4.0]
    v = vs[5]
    assert v.params == {"scenario.road_users.0.x_m": 70.0, "scenario.environment.rain_mm_h": 16.0, "config.seed": 2}
    assert v.scenario["road_users"][0]["x_m"] == 70.0
    assert v.scenario["environment"]["rain_mm_h"] == 16.0
    assert v.scenario["duration_s"] == 0.5
    assert v.config == {"seed": 2}
    # the base is not modified
    assert base_scenario["road_users"][0]["x_m"] == 90.0


def test_bare_dotted_keys_mean_the_same(base_scenario):
    quoted = variants_of(GRID, base_scenario)
    bare = variants_of(GRID.replace('"scenario.road_users.0.x_m"', "scenario.road_users.0.x_m")
                       .replace('"config.seed"', "config.seed"), base_scenario)
    assert sorted(v.hash for v in quoted) == sorted(v.hash for v in bare)


RANDOM = """
[sweep]
design = "random"
samples = 25
seed = 7
[parameters]
"scenario.road_users.0.x_m" = { min = 60.0, max = 160.0 }
"scenario.environment.fog_visibility_m" = { choices = [50.0, 200.0, 1000.0] }
"config.seed" = { min = 1, max = 1000 }
"param.mode" = ["ideal", "physical"]
"""


def test_random_design_deterministic(base_scenario):
    a = variants_of(RANDOM, base_scenario)
    b = variants_of(RANDOM, base_scenario)
    assert len(a) == 25
    assert [v.hash for v in a] == [v.hash for v in b]
    assert [v.params for v in a] == [v.params for v in b]
    for v in a:
        assert 60.0 <= v.params["scenario.road_users.0.x_m"] <= 160.0
        assert v.params["scenario.environment.fog_visibility_m"] in (50.0, 200.0, 1000.0)
        seed = v.params["config.seed"]
        assert isinstance(seed, int) and 1 <= seed <= 1000
        assert v.fmu_params["mode"] in ("ideal", "physical")
        # fog_visibility_m is optional: absent from the printed scenario, accepted and set
        assert v.scenario["environment"]["fog_visibility_m"] == v.params["scenario.environment.fog_visibility_m"]
    other = variants_of(RANDOM.replace("seed = 7", "seed = 8"), base_scenario)
    assert [v.hash for v in other] != [v.hash for v in a]


def test_random_points_match_seeded_rng():
    spec = spec_of(RANDOM)
    assert design_points(spec) == design_points(spec)
    assert len(design_points(spec)) == 25


def test_hash_stable(base_scenario):
    s = copy.deepcopy(base_scenario)
    h = variant_hash(["radar"], s, {"range_m": 80.0}, {"seed": 3}, None)
    # A literal: the hash must not change between Python versions, processes or releases of this
    # package (a re-run keys finished variants by it).
    assert h == EXPECTED_HASH
    # key order does not matter
    s2 = dict(reversed(list(s.items())))
    assert variant_hash(["radar"], s2, {"range_m": 80.0}, {"seed": 3}, None) == h
    # every input matters
    assert variant_hash(["radar"], s, {"range_m": 81.0}, {"seed": 3}, None) != h
    assert variant_hash(["radar"], s, {"range_m": 80.0}, {"seed": 4}, None) != h
    assert variant_hash(["lidar"], s, {"range_m": 80.0}, {"seed": 3}, None) != h
    assert variant_hash(["radar"], s, {"range_m": 80.0}, {"seed": 3}, 10) != h
    s3 = copy.deepcopy(s)
    s3["environment"]["rain_mm_h"] = 1.0
    assert variant_hash(["radar"], s3, {"range_m": 80.0}, {"seed": 3}, None) != h


EXPECTED_HASH = "0325fd703323a60f"


def test_hash_is_sha256_of_canonical_json():
    # printf '%s' '{"config":{},"max_frames":null,"param":{},"scenario":{"a":1},"sensors":["radar"],"v":1}' \
    #   | sha256sum | cut -c1-16
    assert variant_hash(["radar"], {"a": 1}, {}, {}, None) == "ffec0fc5edd73ce9"


@pytest.mark.parametrize(
    "text, message",
    [
        ("[sweep]\n[foo]\n", "foo: unknown table"),
        ("[parameters]\n", "sweep: missing table"),
        ("[sweep]\nsensor = ['radar']\n", "sweep.sensor: unknown key"),
        ("[sweep]\nsensors = 'radar'\n", "sweep.sensors: expected a list"),
        ("[sweep]\nsensors = []\n", "sweep.sensors: empty list"),
        ("[sweep]\nsensors = ['sonar']\n", "sweep.sensors: unknown sensor 'sonar'"),
        ("[sweep]\ndesign = 'lhs'\n", "sweep.design"),
        ("[sweep]\ndesign = 'random'\n", "sweep.samples: a random design needs"),
        ("[sweep]\nsamples = 3\n", "sweep.samples: only for design"),
        ("[sweep]\nmax_frames = true\n", "sweep.max_frames: expected an integer"),
        ("[sweep]\nrange_bins_m = [0, 50, 25]\n", "sweep.range_bins_m: edges must be"),
        ("[sweep]\nrange_bins_m = [0, 'a']\n", "sweep.range_bins_m: expected a number"),
        ("[sweep]\n[scenario]\nfiles = 'x.json'\n", "scenario.files: unknown key"),
        ("[sweep]\n[scenario]\nset = 3\n", "scenario.set: expected a table"),
        ("[sweep]\n[parameters]\n'scenario.environment.rain_mm_h' = []\n",
         "parameters.'scenario.environment.rain_mm_h': empty list"),
        ("[sweep]\n[parameters]\n'scenario.environment.rain_mm_h' = 3.0\n",
         "parameters.'scenario.environment.rain_mm_h': a grid design takes a list"),
        ("[sweep]\n[parameters]\n'rain' = [1.0]\n", "parameters.rain: unknown parameter"),
        ("[sweep]\n[parameters]\n'sensor.seed' = [1]\n", "parameters.'sensor.seed': unknown parameter"),
        ("[sweep]\n[parameters]\n'config.sead' = [1]\n",
         "parameters.'config.sead': unknown sensor configuration key 'sead'"),
        ("[sweep]\n[parameters]\n'config.kind' = ['lidar']\n", "parameters.'config.kind': the sensor kind"),
        ("[sweep]\n[parameters]\n'param.config' = ['{}']\n", "sweep the configuration with config"),
        ("[sweep]\ndesign='random'\nsamples=2\n[parameters]\n'config.seed' = {min = 1}\n",
         "parameters.'config.seed': a random range needs both"),
        ("[sweep]\ndesign='random'\nsamples=2\n[parameters]\n'config.seed' = {min = 5, max = 1}\n",
         "parameters.'config.seed': min 5 > max 1"),
        ("[sweep]\ndesign='random'\nsamples=2\n[parameters]\n'config.seed' = {choices = []}\n",
         "parameters.'config.seed'.choices: expected a non-empty list"),
    ],
)
def test_spec_errors_name_the_key(text, message):
    with pytest.raises(SpecError) as e:
        spec_of(text)
    assert message in str(e.value)


@pytest.mark.parametrize(
    "param, message",
    [
        ("scenario.road_users.9.x_m", "index 9 out of range: road_users has 5 entries"),
        ("scenario.environment.rain", "the scenario has no 'environment.rain'"),
        ("scenario.weather.rain_mm_h", "the scenario has no 'weather'"),
        ("scenario.road_users.first.x_m", "road_users is a list; expected an index"),
        ("scenario.duration_s.x", "duration_s is a float"),
        ("scenario.road_users.0.dimension", "the scenario has no 'road_users.0.dimension'"),
    ],
)
def test_missing_scenario_paths(base_scenario, param, message):
    text = f"[sweep]\n[parameters]\n'{param}' = [1.0]\n"
    with pytest.raises(SpecError) as e:
        variants_of(text, base_scenario)
    assert message in str(e.value)
    assert param in str(e.value)


def test_scenario_set_paths_checked(base_scenario):
    with pytest.raises(SpecError, match=r"scenario\.set\.durations: the scenario has no 'durations'"):
        variants_of("[sweep]\n[scenario]\nset = { durations = 1.0 }\n", base_scenario)
    # nested tables in `set` are dotted paths; optional keys are accepted
    vs = variants_of("[sweep]\n[scenario]\nset = { environment = { fog_visibility_m = 80.0 } }\n", base_scenario)
    assert len(vs) == 1 and vs[0].scenario["environment"]["fog_visibility_m"] == 80.0


def test_fmu_parameter_names_checked(base_scenario):
    text = "[sweep]\n[parameters]\n'param.range' = [80.0]\n"
    with pytest.raises(SpecError, match=r"parameters.'param.range': the radar FMU has no parameter 'range'"):
        variants_of(text, base_scenario, {"radar": {"range_m", "mode", "config"}})
    vs = variants_of("[sweep]\n[parameters]\n'param.range_m' = [60.0, 80.0]\n", base_scenario,
                     {"radar": {"range_m", "mode", "config"}})
    assert [v.fmu_params for v in vs] == [{"range_m": 60.0}, {"range_m": 80.0}]


def test_toml_syntax_error(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[sweep\n")
    with pytest.raises(SpecError, match="TOML syntax error"):
        load_spec(p)
    with pytest.raises(SpecError, match="no such file"):
        load_spec(tmp_path / "missing.toml")


def test_scenario_file_relative_to_spec(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("[sweep]\n[scenario]\nfile = 'base.json'\n")
    assert load_spec(p).scenario_file == tmp_path / "base.json"


def test_config_keys_with_dots(base_scenario):
    # effect names hold dots: a quoted TOML key part stays one key of the configuration
    text = "[sweep]\n[parameters]\nconfig.effects.\"radar.rain\" = [true, false]\n'config.weather.rain_mm_h' = [4.0]\n"
    vs = variants_of(text, base_scenario)
    assert [v.config for v in vs] == [
        {"effects": {"radar.rain": True}, "weather": {"rain_mm_h": 4.0}},
        {"effects": {"radar.rain": False}, "weather": {"rain_mm_h": 4.0}},
    ]


def test_scenario_value_types_checked(base_scenario):
    text = "[sweep]\n[parameters]\n'scenario.environment.rain_mm_h' = [0.0, 'heavy']\n"
    with pytest.raises(SpecError) as e:
        variants_of(text, base_scenario)
    assert str(e.value) == (
        "parameters.'scenario.environment.rain_mm_h': value 'heavy' is a string, but the scenario's "
        "environment.rain_mm_h is a number (0.0)"
    )
    # integers for a real are fine; strings for a string (an enum) too
    vs = variants_of("[sweep]\n[parameters]\n'scenario.environment.rain_mm_h' = [0, 16]\n"
                     "'scenario.road_users.0.kind' = ['car', 'truck']\n", base_scenario)
    assert len(vs) == 4
