"""Traffic lights, traffic signs and lane boundaries from a SensorView that osi-python wrote, through
the packaged camera FMU (physical model), decoded again with osi-python.

The scene is built here with the official `osi3` bindings only: a host on a straight lane with solid
boundaries at ±1.75 m, a 750 mm speed-limit sign and a three-bulb signal head (red lit) ahead on
the right, a stop line. Checks:

* SensorData decodes with osi3 and carries DetectedTrafficLight / DetectedTrafficSign /
  DetectedLaneBoundary with their entity headers; every detection names its ground truth; the red
  bulb is reported lit (CONSTANT) and the dark bulbs OFF; the sign's main-sign type is the speed
  limit; the sign and the bulbs lie where they are (sensor frame, within the size-distance
  estimate's error); the lane-boundary points lie on the painted lines.
* LED flicker: with an exposure below the signal's PWM off-time, `camera.led_flicker` on makes the
  expected fraction 1 − D − t_e·f of frames read the lit red bulb dark (a state misread); with the
  effect off, or with an exposure of a whole PWM period, none do.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from osi3 import osi_common_pb2 as common
from osi3 import osi_environment_pb2 as env
from osi3 import osi_groundtruth_pb2 as gt
from osi3 import osi_lane_pb2 as lane
from osi3 import osi_object_pb2 as obj
from osi3 import osi_roadmarking_pb2 as rmark
from osi3 import osi_sensordata_pb2 as sd
from osi3 import osi_sensorview_pb2 as sv
from osi3 import osi_trafficlight_pb2 as tlight
from osi3 import osi_trafficsign_pb2 as tsign
from osi3 import osi_version_pb2 as version_pb2
from test_fmus import FMU_DIR, OsmpSlave

import fmpy

HOST_ID = 1
SIGN_ID, RED_ID, YELLOW_ID, GREEN_ID, STOP_ID = 70, 80, 81, 82, 90
LEFT_B, RIGHT_B, LANE_ID = 20, 21, 10
HOST_DIM = (4.5, 1.8, 1.4)
BB_TO_REAR = (-1.4, 0.0, -0.3)
# Sign plate centre, bulb centres (global = host frame; host box centre at (0, 0, 0.7)).
SIGN = (22.0, -3.5, 2.4)
SIGN_SIZE = 0.75
HEAD_X, HEAD_Y, GREEN_Z = 30.0, -3.0, 2.6
LENS = 0.3
# The signal's PWM drive, set in the camera's configuration (`render.lamps.signal_pwm_hz`,
# `signal_duty`): 1 kHz, so that a whole period (1 ms) is an exposure a night scene takes unsaturated.
PWM_HZ = 1000.0
DUTY = 0.5


def v3(x, y, z):
    return common.Vector3d(x=x, y=y, z=z)


def base(pos, dim, yaw=0.0):
    return common.BaseStationary(
        dimension=common.Dimension3d(length=dim[0], width=dim[1], height=dim[2]),
        position=v3(*pos),
        orientation=common.Orientation3d(roll=0.0, pitch=0.0, yaw=yaw),
    )


def bulb_z(k):
    return GREEN_Z + 1.5 * LENS * (2 - k)


def ground_truth(t: float, night: bool = False) -> gt.GroundTruth:
    seconds, nanos = divmod(round(t * 1e9), 10**9)
    Mo = obj.MovingObject
    host = Mo(
        id=common.Identifier(value=HOST_ID),
        base=common.BaseMoving(
            dimension=common.Dimension3d(length=HOST_DIM[0], width=HOST_DIM[1], height=HOST_DIM[2]),
            position=v3(0.0, 0.0, 0.7),
            orientation=common.Orientation3d(roll=0.0, pitch=0.0, yaw=0.0),
            velocity=v3(0.0, 0.0, 0.0),
        ),
        type=Mo.TYPE_VEHICLE,
        vehicle_attributes=Mo.VehicleAttributes(bbcenter_to_rear=v3(*BB_TO_REAR)),
        vehicle_classification=Mo.VehicleClassification(type=Mo.VehicleClassification.TYPE_CAR),
    )
    LB = lane.LaneBoundary

    def boundary(bid, y):
        return LB(
            id=common.Identifier(value=bid),
            boundary_line=[LB.BoundaryPoint(position=v3(x, y, 0.0), width=0.15) for x in range(-20, 121, 10)],
            classification=LB.Classification(type=LB.Classification.TYPE_SOLID_LINE, color=LB.Classification.COLOR_WHITE),
        )

    ego_lane = lane.Lane(
        id=common.Identifier(value=LANE_ID),
        classification=lane.Lane.Classification(
            type=lane.Lane.Classification.TYPE_DRIVING,
            is_host_vehicle_lane=True,
            left_lane_boundary_id=[common.Identifier(value=LEFT_B)],
            right_lane_boundary_id=[common.Identifier(value=RIGHT_B)],
        ),
    )
    TS = tsign.TrafficSign
    MSC = TS.MainSign.Classification
    sign = TS(
        id=common.Identifier(value=SIGN_ID),
        main_sign=TS.MainSign(
            base=base(SIGN, (0.02, SIGN_SIZE, SIGN_SIZE), math.pi),
            classification=MSC(
                type=MSC.TYPE_SPEED_LIMIT_BEGIN,
                value=tsign.TrafficSignValue(value=60.0, value_unit=tsign.TrafficSignValue.UNIT_KILOMETER_PER_HOUR),
                variability=TS.VARIABILITY_FIXED,
                country="DE",
                code="274",
            ),
        ),
    )
    TLC = tlight.TrafficLight.Classification
    bulbs = [
        tlight.TrafficLight(
            id=common.Identifier(value=bid),
            base=base((HEAD_X, HEAD_Y, bulb_z(k)), (0.05, LENS, LENS), math.pi),
            classification=TLC(color=color, icon=TLC.ICON_NONE, mode=mode),
        )
        for k, (bid, color, mode) in enumerate(
            [
                (RED_ID, TLC.COLOR_RED, TLC.MODE_CONSTANT),
                (YELLOW_ID, TLC.COLOR_YELLOW, TLC.MODE_OFF),
                (GREEN_ID, TLC.COLOR_GREEN, TLC.MODE_OFF),
            ]
        )
    ]
    RMC = rmark.RoadMarking.Classification
    stop = rmark.RoadMarking(
        id=common.Identifier(value=STOP_ID),
        base=common.BaseStationary(
            dimension=common.Dimension3d(length=0.5, width=3.5, height=0.0),
            position=v3(HEAD_X - 4.0, 0.0, 0.0),
            orientation=common.Orientation3d(roll=0.0, pitch=0.0, yaw=0.0),
            base_polygon=[common.Vector2d(x=x, y=y) for x, y in [(-0.25, -1.75), (0.25, -1.75), (0.25, 1.75), (-0.25, 1.75)]],
        ),
        classification=RMC(type=RMC.TYPE_GENERIC_LINE, monochrome_color=RMC.COLOR_WHITE),
    )
    EC = env.EnvironmentalConditions
    conditions = EC(
        time_of_day=EC.TimeOfDay(seconds_since_midnight=(23 if night else 12) * 3600),
        ambient_illumination=EC.AMBIENT_ILLUMINATION_LEVEL1 if night else EC.AMBIENT_ILLUMINATION_LEVEL9,
    )
    return gt.GroundTruth(
        version=version_pb2.InterfaceVersion(version_major=3, version_minor=8, version_patch=0),
        timestamp=common.Timestamp(seconds=seconds, nanos=nanos),
        environmental_conditions=conditions,
        host_vehicle_id=common.Identifier(value=HOST_ID),
        moving_object=[host],
        lane_boundary=[boundary(LEFT_B, 1.75), boundary(RIGHT_B, -1.75)],
        lane=[ego_lane],
        traffic_sign=[sign],
        traffic_light=bulbs,
        road_marking=[stop],
    )


def merged(base: dict, over: dict) -> dict:
    out = dict(base)
    for k, v in over.items():
        out[k] = merged(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


class Camera:
    """The camera FMU with its shipped configuration (`resources/config.json`) plus `overrides`,
    passed inline, driven through its handshake."""

    def __init__(self, overrides: dict, name: str):
        fmu = FMU_DIR / "camera.fmu"
        if not fmu.exists():
            pytest.fail(f"{fmu} missing: run `cargo run --release -- package --out target/fmu` first")
        self.md = fmpy.read_model_description(str(fmu))
        self.unzip = fmpy.extract(str(fmu))
        shipped = json.loads((Path(self.unzip) / "resources" / "config.json").read_text())
        config = merged(shipped, overrides)
        self.slave = OsmpSlave(self.md, self.unzip, name)
        s = self.slave
        s.slave.instantiate(callbacks=s.callbacks, loggingOn=True)
        s.instantiated = True
        s.slave.setString([s.vr("config", "String")], [json.dumps(config)])
        s.slave.setupExperiment(startTime=0.0)
        s.slave.enterInitializationMode()
        self.request = s.handshake()
        m = self.request.mounting_position
        # Host yaw 0: the sensor sits at box centre + bbcenter_to_rear + mounting position.
        self.sensor = (
            BB_TO_REAR[0] + m.position.x,
            BB_TO_REAR[1] + m.position.y,
            0.7 + BB_TO_REAR[2] + m.position.z,
        )

    def step(self, t: float, h: float, night: bool = False) -> sd.SensorData:
        truth = ground_truth(t, night)
        view = sv.SensorView(
            version=version_pb2.InterfaceVersion(version_major=3, version_minor=8, version_patch=0),
            timestamp=truth.timestamp,
            mounting_position=self.request.mounting_position,
            global_ground_truth=truth,
            host_vehicle_id=common.Identifier(value=HOST_ID),
        )
        if self.request.HasField("sensor_id"):
            view.sensor_id.CopyFrom(self.request.sensor_id)
        for c in self.request.camera_sensor_view_configuration:
            view.camera_sensor_view.add().view_configuration.CopyFrom(c)
        status = self.slave.step(t, h, view.SerializeToString())
        assert status == 0, self.slave.log_tail()
        raw = self.slave.get_binary("OSMPSensorDataOut")
        assert raw, self.slave.log_tail()
        return sd.SensorData.FromString(raw)

    def close(self):
        self.slave.free()


def truth_id(entity) -> int:
    assert len(entity.header.ground_truth_id) == 1
    return entity.header.ground_truth_id[0].value


def run_frames(
    config: dict, n: int, h: float, name: str, night: bool = False
) -> tuple[list[sd.SensorData], tuple]:
    cam = Camera(config, name)
    try:
        frames = [cam.step(k * h, h, night) for k in range(n)]
    finally:
        cam.close()
    return frames, cam.sensor


def red_mode(data: sd.SensorData):
    for light in data.traffic_light:
        if truth_id(light) == RED_ID:
            return light.candidate[0].classification.mode
    return None


def test_detected_traffic_entities_decode_with_osi3():
    config = {"effects": {"camera.led_flicker": False}, "seed": 3}
    frames, sensor = run_frames(config, 3, 0.05, "traffic_decode")
    data = frames[-1]
    TLC = tlight.TrafficLight.Classification
    for header in (data.traffic_light_header, data.traffic_sign_header, data.lane_boundary_header):
        assert header.HasField("measurement_time") and header.cycle_counter == 2
    # Traffic lights: every bulb in view, the red one lit.
    modes = {truth_id(light): light.candidate[0].classification.mode for light in data.traffic_light}
    assert modes.get(RED_ID) == TLC.MODE_CONSTANT, modes
    assert modes.get(YELLOW_ID) == TLC.MODE_OFF and modes.get(GREEN_ID) == TLC.MODE_OFF, modes
    colors = {truth_id(light): light.candidate[0].classification.color for light in data.traffic_light}
    assert colors[RED_ID] == TLC.COLOR_RED
    for light in data.traffic_light:
        k = {RED_ID: 0, YELLOW_ID: 1, GREEN_ID: 2}[truth_id(light)]
        true = (HEAD_X - sensor[0], HEAD_Y - sensor[1], bulb_z(k) - sensor[2])
        p = light.base.position
        r_true = math.dist(true, (0, 0, 0))
        # Size-distance estimate: a 0.3 m lens at ≈ 31 m spans a few px; ±1 px of it.
        assert abs(math.dist((p.x, p.y, p.z), (0, 0, 0)) - r_true) < 0.4 * r_true, (p, true)
        assert abs(math.atan2(p.y, p.x) - math.atan2(true[1], true[0])) < math.radians(1.0)
    # The sign: detected, classified as the speed limit, where it is.
    assert len(data.traffic_sign) == 1, data.traffic_sign
    s = data.traffic_sign[0]
    assert truth_id(s) == SIGN_ID
    cls = s.main_sign.candidate[0].classification
    assert cls.type == tsign.TrafficSign.MainSign.Classification.TYPE_SPEED_LIMIT_BEGIN
    p = s.main_sign.base.position
    true = tuple(SIGN[i] - sensor[i] for i in range(3))
    assert abs(math.dist((p.x, p.y, p.z), (0, 0, 0)) - math.dist(true, (0, 0, 0))) < 0.15 * math.dist(true, (0, 0, 0))
    # Lane boundaries: both lines, their points on the paint (sensor frame: y − sensor y).
    seen = {truth_id(b): b for b in data.lane_boundary}
    assert set(seen) == {LEFT_B, RIGHT_B}, seen.keys()
    for bid, y_line in [(LEFT_B, 1.75), (RIGHT_B, -1.75)]:
        b = seen[bid]
        assert len(b.boundary_line) >= 5 and len(b.boundary_line_confidences) == len(b.boundary_line)
        for q in b.boundary_line:
            x = q.position.x
            # Half a pixel of the ray at the sample's distance plus the line's half width, plus
            # 2 % of the distance for the road height the camera assumes.
            assert abs(q.position.y - (y_line - sensor[1])) < 0.1 + 0.02 * x, (bid, q.position)
        assert b.candidate[0].classification.type == lane.LaneBoundary.Classification.TYPE_SOLID_LINE


@pytest.mark.parametrize(
    "flicker, exposure_s, night",
    [(True, 0.05e-3, False), (True, 0.2e-3, False), (False, 0.05e-3, False), (True, 1.0 / PWM_HZ, True)],
)
def test_flicker_misreads_only_with_the_effect_and_a_short_exposure(flicker, exposure_s, night):
    """A single-exposure camera (HDR `single`: the DOL merge would take the lens from its short
    captures). The red bulb is PWM-driven at 1 kHz with duty 0.5; a capture of t_e that starts at a
    uniformly spread PWM phase sees it entirely dark with probability 1 − D − t_e·f (t_e·f < 1 − D),
    else 0 (physics.md §8.2). The whole-period (1 ms) case is at night (daylight saturates it)."""
    config = {
        # Global shutter: with `camera.rolling_shutter` the lens's rows start their exposures a row
        # time apart, and the lens reads dark only when all of them miss the on-phase (the window
        # grows by the lens's readout span).
        "effects": {"camera.led_flicker": flicker, "camera.rolling_shutter": False},
        "camera": {
            "exposure_s": exposure_s,
            "hdr": {"mode": "single"},
            "render": {"lamps": {"signal_pwm_hz": PWM_HZ, "signal_duty": DUTY}},
        },
        "seed": 5,
    }
    # 20 frames 37.3 ms apart: the PWM phase at exposure start steps by 0.3 of a period each frame,
    # spreading evenly over the period.
    n = 20
    frames, _ = run_frames(config, n, 0.0373, f"flicker_{flicker}_{exposure_s}", night=night)
    modes = [red_mode(f) for f in frames]
    assert all(m is not None for m in modes), modes
    off = sum(m == tlight.TrafficLight.Classification.MODE_OFF for m in modes)
    expected = max(0.0, 1.0 - DUTY - exposure_s * PWM_HZ) if flicker else 0.0
    if expected == 0.0:
        assert off == 0, modes
    else:
        assert abs(off / n - expected) <= 0.15, (off, n, expected, modes)
