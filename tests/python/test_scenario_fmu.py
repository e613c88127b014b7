"""Outside checks of scenario.fmu, the osiris scenario player (an OSMP SensorView source), with FMPy
0.3.32 and the official OSI bindings (osi-python 3.8.0).

The FMU is taken from $OSIRIS_FMU_DIR (default <repo>/target/fmu), as written by
`cargo run --release -- package --out target/fmu`; the official OSMP example FMUs from
/work/shared/fixtures/osmp-dummy (or $OSIRIS_OSMP_DUMMY_DIR). A missing FMU or fixture fails the test.

* modelDescription.xml: `fmpy.validate` finds no problems; the OSMP source variables have the names,
  types and value references of the official OSMPDummySource.
* scenario.fmu alone, through `fmpy.fmi2.FMU2Slave`: the published SensorViews decode with osi3 and
  follow the built-in scenario (timestamps, ids, the constant-velocity motion), `valid` and `count`;
  `fmpy.simulate_fmu` runs it over its default experiment; a bad parameter is an fmi2Error naming it.
* Chains, the master being this test: each step the three OSMP Integers of the source's
  OSMPSensorViewOut are copied to the sensor's OSMPSensorViewIn, then both step.
  - scenario.fmu -> radar.fmu (physical): the radar's SensorData holds detections of the scenario's
    objects and, once tracked, the car ahead.
  - scenario.fmu -> the official OSMPDummySensor (a foreign sensor FMU): it reports the scenario's
    moving objects in front of the ego, closing in on the slower car ahead.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import fmpy
import pytest
from conftest import REPO
from fmpy.fmi1 import FMICallException
from osi3 import osi_sensordata_pb2 as sd
from osi3 import osi_sensorview_pb2 as sv
from osi3 import osi_sensorviewconfiguration_pb2 as svc
from test_fmus import OsmpSlave

FMU_DIR = Path(os.environ.get("OSIRIS_FMU_DIR", REPO / "target" / "fmu"))
DUMMY_DIR = Path(os.environ.get("OSIRIS_OSMP_DUMMY_DIR", "/work/shared/fixtures/osmp-dummy"))
OUT = "OSMPSensorViewOut"

# The built-in scenario (scenario/src/lib.rs, ScenarioConfig::default): ego (id 1) at x = 50 m,
# 25 m/s; the car ahead (id 100) at x = 90 m, 20 m/s, same lane; the truck (id 101) at x = 75 m,
# 22 m/s, left lane; the car behind (id 102) at x = 25 m; cyclist (103), pedestrian (104); 2 s at
# 0.01 s steps; sensors front_camera (id 10), front_radar (20), front_lidar (30).
EGO_ID, AHEAD_ID, TRUCK_ID, BEHIND_ID = 1, 100, 101, 102


def fmu_file(name: str) -> Path:
    path = FMU_DIR / f"{name}.fmu"
    if not path.is_file():
        pytest.fail(
            f"{path} not found: package the FMUs with `cargo run --release -- package --out {FMU_DIR}` "
            "(or point OSIRIS_FMU_DIR at the folder holding them)"
        )
    return path


def dummy_file(name: str) -> Path:
    path = DUMMY_DIR / f"{name}.fmu"
    if not path.is_file():
        pytest.fail(f"{path} not found: the official OSMP example FMUs are a fixture of these tests")
    return path


def open_slave(path: Path, tmp: Path, instance_name: str) -> OsmpSlave:
    unzip = tmp / f"unzip-{path.stem}"
    fmpy.extract(str(path), unzipdir=str(unzip))
    return OsmpSlave(fmpy.read_model_description(str(path)), unzip, instance_name)


def start_source(source: OsmpSlave, **strings: str):
    """instantiate, setupExperiment(0), enter initialization, set the String parameters, exit."""
    source.instantiate()
    for name, value in strings.items():
        source.slave.setString([source.vr(name, "String")], [value])
    source.slave.exitInitializationMode()


def copy_view(source: OsmpSlave, sensor: OsmpSlave):
    """The master's job between steps: the source's output triple to the sensor's input."""
    sensor.slave.setInteger(sensor.triple("OSMPSensorViewIn"), source.slave.getInteger(source.triple(OUT)))


def view_of(source: OsmpSlave) -> sv.SensorView | None:
    raw = source.get_binary(OUT)
    return None if raw is None else sv.SensorView.FromString(raw)


def moving(view: sv.SensorView) -> dict[int, object]:
    return {o.id.value: o for o in view.global_ground_truth.moving_object}


def seconds(ts) -> float:
    return ts.seconds + ts.nanos * 1e-9


# ---------------------------------------------------------------------------------------------
# The FMU alone


def test_fmpy_validate_finds_no_problems():
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu_file("scenario"))) == []


def test_source_variables_match_the_official_dummy_source():
    def table(path: Path) -> dict[str, tuple]:
        with zipfile.ZipFile(path) as zf:
            root = ET.fromstring(zf.read("modelDescription.xml"))
        out = {}
        for v in root.iter("ScalarVariable"):
            ty = next(c.tag for c in v if c.tag != "Annotations")
            ann = v.find(".//{http://xsd.pmsf.net/OSISensorModelPackaging}osmp-binary-variable")
            out[v.get("name")] = (
                ty,
                v.get("valueReference"),
                v.get("causality"),
                v.get("variability"),
                None if ann is None else (ann.get("name"), ann.get("role"), ann.get("mime-type")),
            )
        return out

    ours, theirs = table(fmu_file("scenario")), table(dummy_file("OSMPDummySource"))
    assert set(theirs) == {f"{OUT}.base.lo", f"{OUT}.base.hi", f"{OUT}.size", "valid", "count"}
    for name, row in theirs.items():
        assert ours[name] == row, name
    # Our parameters on top.
    assert {n: ours[n][:4] for n in set(ours) - set(theirs)} == {
        "scenario": ("String", "0", "parameter", "fixed"),
        "trace_path": ("String", "1", "parameter", "fixed"),
        "sensor": ("String", "2", "parameter", "fixed"),
    }


def test_plays_the_built_in_scenario(tmp_path):
    source = open_slave(fmu_file("scenario"), tmp_path, "scenario")
    try:
        start_source(source, sensor="front_radar")
        h = 0.01
        t = 0.0
        views = [view_of(source)]  # the view at the start time, published by initialization
        for _ in range(10):
            source.slave.doStep(t, h)
            t += h
            views.append(view_of(source))
        for k, view in enumerate(views):
            assert view is not None and source.get_bool("valid")
            assert seconds(view.timestamp) == pytest.approx(k * h, abs=1e-9)
            assert seconds(view.global_ground_truth.timestamp) == pytest.approx(k * h, abs=1e-9)
            assert view.sensor_id.value == 20 and len(view.radar_sensor_view) == 1
            assert view.host_vehicle_id.value == EGO_ID
            assert view.HasField("mounting_position")
            objs = moving(view)
            assert EGO_ID in objs and AHEAD_ID in objs and BEHIND_ID in objs
            # Constant velocity along the road.
            assert objs[EGO_ID].base.position.x == pytest.approx(50.0 + 25.0 * k * h, abs=1e-9)
            assert objs[AHEAD_ID].base.position.x == pytest.approx(90.0 + 20.0 * k * h, abs=1e-9)
            assert objs[AHEAD_ID].base.velocity.x == pytest.approx(20.0)
        assert source.get_int("count") == len(views[-1].global_ground_truth.moving_object) == 6
    finally:
        source.free()


def test_simulate_fmu_over_the_default_experiment():
    result = fmpy.simulate_fmu(str(fmu_file("scenario")), output=["valid", "count", f"{OUT}.size"])
    # 2 s at 0.01 s; valid up to and including t = duration_s.
    assert result["time"][-1] == pytest.approx(2.0)
    assert all(result["valid"])
    assert all(result["count"] == 6)
    assert all(result[f"{OUT}.size"] > 0)


def test_a_bad_parameter_is_an_error_naming_it(tmp_path):
    source = open_slave(fmu_file("scenario"), tmp_path, "scenario")
    try:
        source.instantiate()
        missing = tmp_path / "nowhere.osi"
        source.slave.setString([source.vr("trace_path", "String")], [str(missing)])
        with pytest.raises(FMICallException):
            source.slave.exitInitializationMode()
        errors = [line for line in source.log if line.startswith("[3]")]
        assert any("`trace_path`" in e and str(missing) in e for e in errors), source.log_tail()
    finally:
        source.instantiated = False  # no fmi2Terminate in the error state
        source.slave.fmi2FreeInstance(source.slave.component)
        source.slave.freeLibrary()


# ---------------------------------------------------------------------------------------------
# Chains


def test_scenario_drives_the_radar_fmu(tmp_path):
    source = open_slave(fmu_file("scenario"), tmp_path, "scenario")
    radar = open_slave(fmu_file("radar"), tmp_path, "front_radar")
    try:
        start_source(source, sensor="front_radar")
        radar.instantiate()
        radar.handshake()
        h = 0.05  # the radar's cycle
        t = 0.0
        frames = []
        for _ in range(12):
            copy_view(source, radar)
            radar.slave.doStep(t, h)  # FMPy raises on Discard/Error/Fatal
            source.slave.doStep(t, h)
            raw = radar.get_binary("OSMPSensorDataOut")
            assert raw, radar.log_tail()
            frames.append(sd.SensorData.FromString(raw))
            t += h
        # The radar saw the world at its communication points.
        for k, data in enumerate(frames):
            assert seconds(data.timestamp) == pytest.approx(k * h, abs=1e-9)
            assert data.sensor_id.value == 20
        # From its first cycle the radar detects something straight ahead (the car ahead).
        first = [d for r in frames[0].feature_data.radar_sensor for d in r.detection]
        assert any(abs(d.position.azimuth) < 0.05 for d in first), [d.position for d in first]
        # Its tracker reports the car ahead as a moving object once confirmed, and (OSI 3.8.0) the
        # detections name that detected object by its tracking id, whose header names the ground
        # truth: the car ahead, never the ego or the car behind.
        tracked, associated = set(), set()
        for data in frames:
            tracks = {
                o.header.tracking_id.value: {i.value for i in o.header.ground_truth_id}
                for o in list(data.moving_object) + list(data.stationary_object)
            }
            for gt in tracks.values():
                tracked.update(gt)
            for r in data.feature_data.radar_sensor:
                for d in r.detection:
                    if d.HasField("object_id"):
                        assert d.object_id.value in tracks, d.object_id.value
                        associated.update(tracks[d.object_id.value])
        assert AHEAD_ID in tracked, tracked
        assert AHEAD_ID in associated, associated
        assert EGO_ID not in associated and BEHIND_ID not in associated, associated
    finally:
        radar.free()
        source.free()


def _dummy_sensor_chain(fmu_dir: str, dummy_dir: str, tmp: str) -> list[dict]:
    """scenario.fmu -> OSMPDummySensor, 10 steps of 0.02 s; per step the dummy's reported objects.
    Runs in a child process (the protobuf-linked example FMUs abort when another one was loaded in
    the same process; this keeps the pytest process clean)."""
    tmp_path = Path(tmp)
    source = open_slave(Path(fmu_dir) / "scenario.fmu", tmp_path, "scenario")
    dummy = open_slave(Path(dummy_dir) / "OSMPDummySensor.fmu", tmp_path, "dummy")
    frames = []
    try:
        start_source(source)
        dummy.instantiate()
        request = dummy.get_binary("OSMPSensorViewInConfigRequest")
        if request:
            svc.SensorViewConfiguration.FromString(request)
            dummy.set_binary("OSMPSensorViewInConfig", request)
        dummy.slave.exitInitializationMode()
        h = 0.02
        t = 0.0
        for _ in range(10):
            copy_view(source, dummy)
            dummy.slave.doStep(t, h)
            source.slave.doStep(t, h)
            raw = dummy.get_binary("OSMPSensorDataOut")
            data = sd.SensorData.FromString(raw) if raw else sd.SensorData()
            frames.append(
                {
                    "valid": dummy.get_bool("valid"),
                    "count": dummy.get_int("count"),
                    "objects": {
                        str(o.header.ground_truth_id[0].value): o.base.position.x for o in data.moving_object
                    },
                }
            )
            t += h
    finally:
        dummy.free()
        source.free()
    return frames


def test_scenario_drives_the_official_dummy_sensor(tmp_path):
    fmu_file("scenario")
    dummy_file("OSMPDummySensor")
    code = (
        "import json, sys; sys.path.insert(0, sys.argv[1]); "
        "import test_scenario_fmu as t; "
        "print(json.dumps(t._dummy_sensor_chain(*sys.argv[2:])))"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, str(Path(__file__).parent), str(FMU_DIR), str(DUMMY_DIR), str(tmp_path)],
        capture_output=True,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr.decode(errors="replace")[-4000:]
    frames = json.loads(proc.stdout.decode().strip().splitlines()[-1])
    assert len(frames) == 10
    for f in frames:
        assert f["valid"] and f["count"] == len(f["objects"]) > 0, f
        ids = {int(i) for i in f["objects"]}
        # The car ahead and the truck in the left lane are in front; the ego and the car behind are not.
        assert {AHEAD_ID, TRUCK_ID} <= ids, ids
        assert EGO_ID not in ids and BEHIND_ID not in ids, ids
    # The car ahead is slower (20 vs 25 m/s): its distance shrinks by 5 m/s · 0.02 s per step.
    ahead = [f["objects"][str(AHEAD_ID)] for f in frames]
    assert 30.0 < ahead[0] < 45.0, ahead
    for a, b in zip(ahead, ahead[1:]):
        assert b - a == pytest.approx(-0.1, abs=1e-6)
