"""Command lines of a variant and the lookup of the binary (no osiris run)."""

import json
import os
import stat

import pytest

from osiris_sweep import runner

RADAR_DEFAULT = {"kind": "radar", "mode": "physical", "range_m": 100.0, "mounting": {"position_m": [3.7, 0, 0.5]}}
LIDAR_DEFAULT = {"kind": "lidar", "mode": "physical", "range_m": 200.0}


def variant(**kw):
    v = {"hash": "0123456789abcdef", "sensors": ["radar"], "fmu_params": {}, "config": {}, "max_frames": None,
         "timeout_s": 60.0, "fmu_dir": None, "scenario": {}}
    v.update(kw)
    return v


def test_one_run_without_config():
    cmds = runner.invocations(variant(sensors=["radar", "lidar"], fmu_params={"range_m": 80.0, "mode": "ideal"},
                                      max_frames=5, fmu_dir="/fmus"), "/bin/osiris", "/tmp/v", "/tmp/v/s.json")
    assert cmds == [([
        "/bin/osiris", "run", "--scenario", "/tmp/v/s.json", "--sensors", "radar,lidar", "--out", "/tmp/v/run0",
        "--quiet", "--format", "osi", "--fmu-dir", "/fmus", "--max-frames", "5",
        "--param", "mode=ideal", "--param", "range_m=80.0",
    ], "/tmp/v/run0")]


def test_config_merged_into_each_sensors_defaults():
    # `--param config={"seed": 3}` alone is rejected by the FMU (missing `kind`): the overrides are
    # merged into the sensor's full default configuration, one run per sensor.
    v = variant(sensors=["radar", "lidar"], config={"seed": 3, "mounting": {"position_m": [1, 2, 3]}},
                config_defaults={"radar": RADAR_DEFAULT, "lidar": LIDAR_DEFAULT})
    cmds = runner.invocations(v, "osiris", "/tmp/v", "/tmp/v/s.json")
    assert [c[1] for c in cmds] == ["/tmp/v/run0", "/tmp/v/run1"]
    configs = []
    for cmd, _ in cmds:
        assert cmd[cmd.index("--sensors") + 1] in ("radar", "lidar")
        (arg,) = [a for a in cmd if a.startswith("config=")]
        configs.append(json.loads(arg[len("config="):]))
    assert configs[0] == {"kind": "radar", "mode": "physical", "range_m": 100.0, "seed": 3,
                          "mounting": {"position_m": [1, 2, 3]}}
    assert configs[1] == {"kind": "lidar", "mode": "physical", "range_m": 200.0, "seed": 3,
                          "mounting": {"position_m": [1, 2, 3]}}
    assert RADAR_DEFAULT["mounting"] == {"position_m": [3.7, 0, 0.5]}  # defaults untouched


def test_config_without_defaults_fails():
    with pytest.raises(runner.RunFailed, match="no default configuration"):
        runner.invocations(variant(config={"seed": 1}), "osiris", "/tmp/v", "/tmp/v/s.json")


def exe(path):
    path.write_text("#!/bin/sh\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return path


def test_binary_lookup_order(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "target/release").mkdir(parents=True)
    local = exe(tmp_path / "target/release/osiris")
    bindir = tmp_path / "bin"
    bindir.mkdir()
    on_path = exe(bindir / "osiris")
    env = exe(tmp_path / "env-osiris")
    explicit = exe(tmp_path / "explicit-osiris")
    monkeypatch.setenv("PATH", str(bindir))
    monkeypatch.setenv("OSIRIS_BIN", str(env))
    assert runner.find_osiris(str(explicit)) == str(explicit)
    assert runner.find_osiris(None) == str(env)
    monkeypatch.delenv("OSIRIS_BIN")
    assert runner.find_osiris(None) == str(on_path)
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert runner.find_osiris(None) == str(local)
    os.remove(local)
    with pytest.raises(runner.BinaryNotFound, match="cannot find the osiris binary"):
        runner.find_osiris(None)
    with pytest.raises(runner.BinaryNotFound, match="--osiris .*: not an executable file"):
        runner.find_osiris(str(tmp_path / "nope"))
