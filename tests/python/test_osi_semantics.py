"""OSI 3.8.0 detection semantics of every SensorData osiris writes (`osiris_models::semantics`),
checked with the official osi-python 3.8.0 classes on `osiris run` of the default scenario, in the
physical (default) and the ideal mode:

* every detection's ``object_id`` is unset or the ``header.tracking_id`` of a detected (moving or
  stationary) object of the same message, and the physical radar and LiDAR do associate some;
* ground-truth stationary objects (corner reflector, board, cone, guardrail) never appear in
  ``moving_object``; ground-truth moving objects (the road users) never in ``stationary_object``;
* camera ``IMAGE_SHAPE_TYPE_BOX`` detections have 2 or 3 points, inside the message's point list;
* pedestrian candidates carry ``head_pose`` and ``upper_body_pose``; on the scenario's pedestrian
  (skeleton with the head turned 20° to the left, walking along the road like the ego) they are
  the skeleton's, relative to the host vehicle: upper body 0°, head 20°.

The ground-truth ids come from the scenario JSON (`osiris scenario`) and the id scheme documented
in `src/scenario.rs`, not from the outputs under test.

Binary: ``$OSIRIS_BIN`` when set, else ``cargo run --release --``; FMUs from ``$OSIRIS_FMU_DIR``
(``--fmu-dir``) when set.
"""

from __future__ import annotations

import json
import math
import os
import struct
import subprocess
from pathlib import Path

import pytest
from osi3.osi_featuredata_pb2 import CameraDetection
from osi3.osi_object_pb2 import MovingObject
from osi3.osi_sensordata_pb2 import SensorData

REPO = Path(__file__).resolve().parents[2]
MODES = ("physical", "ideal")
PEDESTRIAN_HEAD_YAW_DEG = 20.0


def osiris_cmd() -> list[str]:
    exe = os.environ.get("OSIRIS_BIN")
    return [exe] if exe else ["cargo", "run", "--release", "--quiet", "--"]


def read_trace(path: Path) -> list[SensorData]:
    """A `.osi` trace: messages each preceded by a 4-byte little-endian length."""
    data = path.read_bytes()
    out, i = [], 0
    while i < len(data):
        assert i + 4 <= len(data), f"{path}: truncated length at byte {i}"
        (n,) = struct.unpack_from("<I", data, i)
        i += 4
        assert i + n <= len(data), f"{path}: truncated message at byte {i}"
        msg = SensorData()
        msg.ParseFromString(data[i : i + n])
        out.append(msg)
        i += n
    return out


@pytest.fixture(scope="session")
def scenario() -> dict:
    proc = subprocess.run(osiris_cmd() + ["scenario"], cwd=REPO, capture_output=True, timeout=3600, check=False)
    assert proc.returncode == 0, proc.stderr.decode(errors="replace")[-4000:]
    return json.loads(proc.stdout)


@pytest.fixture(scope="session")
def truth_ids(scenario) -> dict:
    """Ground-truth ids by kind, from the scenario JSON and the documented id scheme (ego `1` or
    `ego.id`, road users `100 + i`, static objects `500 + i`, guardrail `900`, traffic signs
    `3000 + i`, signal-head bulbs `4000 + 10 i + b`, road markings `5000 + i`, explicit ids win).
    Traffic signs, bulbs and markings are stationary ground truth."""
    moving = {scenario["ego"].get("id", 1)}
    pedestrians = set()
    for i, u in enumerate(scenario["road_users"]):
        oid = u.get("id", 100 + i)
        moving.add(oid)
        if u["kind"] == "pedestrian":
            pedestrians.add(oid)
    stationary = {s.get("id", 500 + i) for i, s in enumerate(scenario["static_objects"])}
    if scenario.get("guardrail"):
        stationary.add(scenario["guardrail"].get("id", 900))
    stationary |= {s.get("id", 3000 + i) for i, s in enumerate(scenario.get("traffic_signs", []))}
    for i, h in enumerate(scenario.get("signal_heads", [])):
        stationary |= {h.get("id", 4000 + 10 * i) + b for b in range(3)}
    stationary |= {m.get("id", 5000 + i) for i, m in enumerate(scenario.get("road_markings", []))}
    assert not moving & stationary
    return {"moving": moving, "stationary": stationary, "pedestrians": pedestrians}


@pytest.fixture(scope="session", params=MODES)
def default_run(request, tmp_path_factory) -> dict:
    mode = request.param
    out = tmp_path_factory.mktemp(f"osi-semantics-{mode}")
    cmd = osiris_cmd() + ["run", "--out", str(out), "--quiet"]
    fmu_dir = os.environ.get("OSIRIS_FMU_DIR")
    if fmu_dir:
        cmd += ["--fmu-dir", fmu_dir]
    if mode != "physical":
        cmd += ["--param", f"mode={mode}"]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, timeout=3600, check=False)
    assert proc.returncode == 0, proc.stderr.decode(errors="replace")[-4000:]
    traces = {}
    for path in sorted(out.glob("*_sd_*.osi")):
        sensor = path.stem.rsplit("_", 1)[-1]
        traces[sensor] = read_trace(path)
    assert sorted(traces) == ["front-camera", "front-lidar", "front-radar"], sorted(traces)
    for sensor, msgs in traces.items():
        assert len(msgs) >= 10, f"{sensor}: {len(msgs)} messages"
    return {"mode": mode, "traces": traces}


def detections(msg: SensorData):
    """(sensor kind, detection) of every feature-data detection."""
    fd = msg.feature_data
    for blk in fd.radar_sensor:
        for d in blk.detection:
            yield "radar", d
    for blk in fd.lidar_sensor:
        for d in blk.detection:
            yield "lidar", d
    for blk in fd.camera_sensor:
        for d in blk.detection:
            yield "camera", d


def tracking_ids(msg: SensorData) -> set[int]:
    ids = set()
    for o in list(msg.moving_object) + list(msg.stationary_object):
        assert o.header.HasField("tracking_id"), "a detected object without tracking_id"
        ids.add(o.header.tracking_id.value)
    return ids


def test_detection_object_ids_name_detected_objects(default_run):
    for sensor, msgs in default_run["traces"].items():
        associated = total = 0
        for k, msg in enumerate(msgs):
            ids = tracking_ids(msg)
            objects = list(msg.moving_object) + list(msg.stationary_object)
            assert len(ids) == len(objects), f"{sensor} message {k}: tracking ids not unique"
            for kind, d in detections(msg):
                total += 1
                if d.HasField("object_id"):
                    associated += 1
                    assert d.object_id.value in ids, (
                        f"{sensor} message {k}: {kind} detection object_id {d.object_id.value} "
                        f"is no detected object's tracking id {sorted(ids)}"
                    )
        assert total > 0, f"{sensor}: no detections"
        # Not vacuous: the trackers' confirmed objects own detections.
        assert associated > 0, f"{sensor}: no detection is associated to a detected object"
        if default_run["mode"] == "ideal":
            assert associated == total, f"{sensor}: ideal detections all belong to reported objects"


def test_stationary_ground_truth_is_never_a_moving_object(default_run, truth_ids):
    for sensor, msgs in default_run["traces"].items():
        n_stationary = 0
        for k, msg in enumerate(msgs):
            for o in msg.moving_object:
                for g in o.header.ground_truth_id:
                    assert g.value not in truth_ids["stationary"], (
                        f"{sensor} message {k}: moving object {o.header.tracking_id.value} has the "
                        f"stationary ground truth {g.value}"
                    )
                    assert g.value in truth_ids["moving"], f"{sensor} message {k}: unknown ground truth {g.value}"
            for o in msg.stationary_object:
                n_stationary += 1
                assert len(o.candidate) >= 1 and o.candidate[0].HasField("classification")
                assert o.header.HasField("existence_probability") and o.header.HasField("measurement_state")
                assert o.base.HasField("position") and o.base.HasField("dimension") and o.base.HasField("orientation")
                for g in o.header.ground_truth_id:
                    assert g.value in truth_ids["stationary"], (
                        f"{sensor} message {k}: stationary object with the moving ground truth {g.value}"
                    )
        # The LiDAR sees the static targets and the guardrail (ideal: every sensor does).
        if sensor == "front-lidar" or default_run["mode"] == "ideal":
            assert n_stationary > 0, f"{sensor}: no stationary object reported"


def test_camera_boxes_have_two_or_three_points(default_run):
    box = CameraDetection.IMAGE_SHAPE_TYPE_BOX
    n = 0
    for k, msg in enumerate(default_run["traces"]["front-camera"]):
        for blk in msg.feature_data.camera_sensor:
            for d in blk.detection:
                if d.image_shape_type == box:
                    n += 1
                    assert d.number_of_points in (2, 3), f"message {k}: box with {d.number_of_points} points"
                    assert d.first_point_index + d.number_of_points <= len(blk.point)
                    pts = blk.point[d.first_point_index : d.first_point_index + d.number_of_points]
                    # First and third corner: top-left (larger azimuth and elevation) first.
                    if d.number_of_points == 2:
                        assert pts[0].point.azimuth >= pts[1].point.azimuth
                        assert pts[0].point.elevation >= pts[1].point.elevation
    assert n > 0, "no camera box detections"


def wrap_deg(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def test_pedestrian_candidates_have_head_and_upper_body_poses(default_run, truth_ids, scenario):
    pedestrian = MovingObject.TYPE_PEDESTRIAN
    ped_users = [u for u in scenario["road_users"] if u["kind"] == "pedestrian"]
    assert ped_users and not any(u.get("heading_rad", 0.0) for u in ped_users)
    assert scenario["ego"].get("heading_rad", 0.0) == 0.0
    n = on_truth = 0
    for sensor, msgs in default_run["traces"].items():
        for k, msg in enumerate(msgs):
            for o in msg.moving_object:
                gts = {g.value for g in o.header.ground_truth_id}
                for c in o.candidate:
                    if c.type != pedestrian:
                        continue
                    n += 1
                    assert c.HasField("head_pose") and c.HasField("upper_body_pose"), (
                        f"{sensor} message {k}: pedestrian candidate without head/upper-body pose"
                    )
                    if gts & truth_ids["pedestrians"]:
                        on_truth += 1
                        # Host frame: the ego and the pedestrian both head along the road.
                        head, upper = math.degrees(c.head_pose.yaw), math.degrees(c.upper_body_pose.yaw)
                        assert abs(wrap_deg(upper)) < 0.01, f"{sensor} message {k}: upper body {upper}°"
                        assert abs(wrap_deg(head - PEDESTRIAN_HEAD_YAW_DEG)) < 0.01, f"{sensor} message {k}: head {head}°"
    assert n > 0, "no pedestrian candidates"
    # The camera (and every ideal sensor that sees it) recognises the scenario's pedestrian.
    assert on_truth > 0, "no pedestrian candidate on the scenario's pedestrian"
