"""ASAM's OSI trace checker (qc-osi-trace, with the OSI 3.8.0 rules) on the traces of the default
`osiris run`: every SensorData trace, and every recorded input SensorView trace, with 0 issues.

The checker lives in `.qc-venv` (made by `.ci/setup-qc` from ../shared/tools/qc-osi-trace); it is
not optional: without it this test fails and says how to install it.
"""

from __future__ import annotations

import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from conftest import REPO

QC = REPO / ".qc-venv" / "bin" / "qc_ositrace"
RULES_DIR = REPO.parent / "shared" / "tools" / "qc-osi-trace"
RULES = RULES_DIR / "osi_3_8_0_rules.yml"


def check(trace: Path, osi_type: str, work: Path) -> list[str]:
    """Run the checker on one trace; the issue descriptions."""
    assert QC.exists(), f"{QC} is missing: run .ci/setup-qc"
    assert RULES.exists(), f"{RULES} is missing (the OSI 3.8.0 rules beside the checkout)"
    result = work / f"{trace.stem}.xqar"
    config = work / f"{trace.stem}.xml"
    config.write_text(
        f"""<?xml version="1.0" encoding="UTF-8" standalone="no"?>
<Config>
  <Param name="InputFile" value="{trace}" />
  <Param name="osiType" value="{osi_type}" />
  <Param name="osiVersion" value="3.8.0" />
  <CheckerBundle application="osiBundle">
    <Param name="resultFile" value="{result}" />
    <Checker checkerId="validator_osi" maxLevel="1" minLevel="3" />
  </CheckerBundle>
</Config>
"""
    )
    proc = subprocess.run(
        [str(QC), "-c", str(config), "--osiRulesFile", str(RULES), "-r", str(result)],
        capture_output=True,
        timeout=1800,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr.decode(errors="replace")[-4000:]
    root = ET.parse(result).getroot()
    checkers = root.findall(".//Checker")
    # Both checkers ran to completion: an empty report from a checker that skipped proves nothing.
    assert {c.get("checkerId") for c in checkers} >= {"deserialization_osi", "osirules_osi"}
    assert all(c.get("status") == "completed" for c in checkers), [c.attrib for c in checkers]
    return [i.get("description", "") for i in root.iter("Issue")]


def test_the_checker_finds_a_planted_violation(default_run, tmp_path):
    """The checker as installed here reports a planted rule break (a negative timestamp in one
    of our SensorData messages): a checker that reports nothing because it checks nothing would
    make the 0-issue tests below worthless."""
    from osi3.osi_sensordata_pb2 import SensorData

    radar = default_run.traces("sd")["front-radar"]
    data = radar.read_bytes()
    n = int.from_bytes(data[:4], "little")
    sd = SensorData()
    sd.ParseFromString(data[4 : 4 + n])
    sd.timestamp.seconds = -5
    bad = sd.SerializeToString()
    planted = tmp_path / "planted_sd_380_0.osi"
    planted.write_bytes(len(bad).to_bytes(4, "little") + bad)
    issues = check(planted, "SensorData", tmp_path)
    assert any("seconds" in i for i in issues), issues


@pytest.mark.parametrize("sensor", ["front-camera", "front-radar", "front-lidar"])
def test_sensor_data_traces_have_no_issues(default_run, sensor, tmp_path):
    trace = default_run.traces("sd")[sensor]
    issues = check(trace, "SensorData", tmp_path)
    assert issues == [], f"{len(issues)} issues, first: {issues[:5]}"


@pytest.mark.parametrize("sensor", ["front-camera", "front-radar", "front-lidar"])
def test_recorded_sensor_view_traces_have_no_issues(default_run, sensor, tmp_path):
    """The SensorViews the run fed each sensor (the built-in scenario's output) follow the OSI
    rules too, e.g. the pedestrian's `pedestrian_attributes`."""
    trace = default_run.traces("sv")[sensor]
    issues = check(trace, "SensorView", tmp_path)
    assert issues == [], f"{len(issues)} issues, first: {issues[:5]}"
