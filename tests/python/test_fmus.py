"""Outside checks of the packaged sensor FMUs (camera.fmu, radar.fmu, lidar.fmu) with FMPy 0.3.32 and
the official OSI bindings (osi-python 3.8.0).

The FMUs are taken from $OSIRIS_FMU_DIR (default <repo>/target/fmu), as written by
`cargo run --release -- package --out target/fmu`.

* modelDescription.xml: `fmpy.validate` finds no problems; the variable-table contract; the OSMP
  annotations (marker, one annotation per triple variable, identical MIME types).
* An OSMP importer written with `fmpy.fmi2.FMU2Slave` + ctypes (variables looked up by name):
  configuration handshake (the request decodes as osi3.SensorViewConfiguration; reading the triple
  in separate calls gives the same buffer), 5 steps with osi3-encoded SensorViews of a fixed scene
  (front car in view, car behind, car beyond range, car hidden behind the front car), SensorData
  decoded with osi3 and checked: detected objects and feature-data detections, frames, headers,
  timestamps, version; OSMP double buffering of the outputs; PerceptionDataOut.
* Robustness: a step without input (address/size 0), a step with garbage bytes, two instances of
  one FMU in one process, `fmpy.simulate_fmu` with no inputs connected.
"""

from __future__ import annotations

import ctypes
import math
import os
import random
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import fmpy
import pytest
from conftest import REPO
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2OK,
    fmi2True,
    fmi2Warning,
)
from fmpy.logging import addLoggerProxy
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.unknown_fields import UnknownFieldSet
from osi3 import osi_common_pb2 as common
from osi3 import osi_groundtruth_pb2 as gt
from osi3 import osi_object_pb2 as obj
from osi3 import osi_sensordata_pb2 as sd
from osi3 import osi_sensorview_pb2 as sv
from osi3 import osi_sensorviewconfiguration_pb2 as svc
from osi3 import osi_version_pb2 as version_pb2

FMU_DIR = Path(os.environ.get("OSIRIS_FMU_DIR", REPO / "target" / "fmu"))
KINDS = ["camera", "radar", "lidar"]
OSMP_TOOL = "net.pmsf.osmp"
OSMP_NS = "{http://xsd.pmsf.net/OSISensorModelPackaging}"
MIME_OSI = "application/x-open-simulation-interface; type={}; version=3.8.0"
MIME_PERCEPTION = "application/x-osiris-perception-data; type=PerceptionData; version=1.0.0"

# The variable-table contract shared by all sensor FMUs: name -> (type, value reference).
CONTRACT = {
    "OSMPSensorViewIn.base.lo": ("Integer", 0),
    "OSMPSensorViewIn.base.hi": ("Integer", 1),
    "OSMPSensorViewIn.size": ("Integer", 2),
    "OSMPSensorDataOut.base.lo": ("Integer", 3),
    "OSMPSensorDataOut.base.hi": ("Integer", 4),
    "OSMPSensorDataOut.size": ("Integer", 5),
    "OSMPSensorViewInConfigRequest.base.lo": ("Integer", 6),
    "OSMPSensorViewInConfigRequest.base.hi": ("Integer", 7),
    "OSMPSensorViewInConfigRequest.size": ("Integer", 8),
    "OSMPSensorViewInConfig.base.lo": ("Integer", 9),
    "OSMPSensorViewInConfig.base.hi": ("Integer", 10),
    "OSMPSensorViewInConfig.size": ("Integer", 11),
    "PerceptionDataOut.base.lo": ("Integer", 12),
    "PerceptionDataOut.base.hi": ("Integer", 13),
    "PerceptionDataOut.size": ("Integer", 14),
    "count": ("Integer", 15),
    "valid": ("Boolean", 0),
    "range_m": ("Real", 0),
    "fov_horizontal_rad": ("Real", 1),
    "fov_vertical_rad": ("Real", 2),
    "config": ("String", 0),
    "mode": ("String", 1),
}
BINARY_VARIABLES = {
    "OSMPSensorViewIn": MIME_OSI.format("SensorView"),
    "OSMPSensorDataOut": MIME_OSI.format("SensorData"),
    "OSMPSensorViewInConfigRequest": MIME_OSI.format("SensorViewConfiguration"),
    "OSMPSensorViewInConfig": MIME_OSI.format("SensorViewConfiguration"),
    "PerceptionDataOut": MIME_PERCEPTION,
}
FEATURE_LIST = {"camera": "camera_sensor", "radar": "radar_sensor", "lidar": "lidar_sensor"}

# Ground-truth ids of the scene.
HOST_ID, FRONT_ID, BEHIND_ID, FAR_ID, HIDDEN_ID = 0, 42, 43, 44, 45


# ---------------------------------------------------------------------------------------------
# Fixtures


@pytest.fixture(scope="module", params=KINDS)
def kind(request) -> str:
    return request.param


@pytest.fixture(scope="module")
def fmu_path(kind) -> Path:
    path = FMU_DIR / f"{kind}.fmu"
    if not path.is_file():
        pytest.fail(
            f"{path} not found: build the FMUs with `cargo run --release -- package --out {FMU_DIR}` "
            "(or point OSIRIS_FMU_DIR at a folder holding camera.fmu, radar.fmu and lidar.fmu)"
        )
    return path


@pytest.fixture(scope="module")
def model_description(fmu_path):
    return fmpy.read_model_description(str(fmu_path))


@pytest.fixture(scope="module")
def unzip_dir(fmu_path, tmp_path_factory):
    d = tmp_path_factory.mktemp(f"unzip-{fmu_path.stem}")
    fmpy.extract(str(fmu_path), unzipdir=str(d))
    return d


@pytest.fixture(scope="module")
def xml_root(fmu_path):
    with zipfile.ZipFile(fmu_path) as zf:
        return ET.fromstring(zf.read("modelDescription.xml"))


@pytest.fixture(scope="session")
def perception_class(osi_wire, tmp_path_factory):
    """osiris.perception.PerceptionData as a Python class, from our own descriptor set (there is
    no official oracle for the extension; this still decodes it with an independent runtime)."""
    path = tmp_path_factory.mktemp("fds-fmu") / "osiris.pb"
    osi_wire.run("descriptor-set", path)
    pool = descriptor_pool.DescriptorPool()
    for f in descriptor_pb2.FileDescriptorSet.FromString(path.read_bytes()).file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("osiris.perception.PerceptionData"))


# ---------------------------------------------------------------------------------------------
# The OSMP importer


def _signed32(x: int) -> int:
    return x - 2**32 if x >= 2**31 else x


class OsmpSlave:
    """One FMU instance driven the OSMP way. Variables are looked up by name."""

    def __init__(self, model_description, unzip_dir: Path, instance_name: str):
        self.md = model_description
        self.vars = {v.name: v for v in model_description.modelVariables}
        self.log: list[str] = []
        self.slave = FMU2Slave(
            guid=model_description.guid,
            unzipDirectory=str(unzip_dir),
            modelIdentifier=model_description.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        # Callbacks with our own logger (through FMPy's C proxy, which formats the variadic
        # message); keep them referenced for the lifetime of the instance.
        self._logger = fmi2CallbackLoggerTYPE(self._log)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy.free)
        addLoggerProxy(ctypes.byref(self.callbacks))
        self._inputs: dict[str, ctypes.Array] = {}  # ctypes buffers the FMU may still read
        self.instantiated = False
        self.freed = False

    def _log(self, env, instance_name, status, category, message):
        category = (category or b"").decode(errors="replace")
        self.log.append(f"[{status}] {category}: {(message or b'').decode(errors='replace')}")

    def log_tail(self, n=15) -> str:
        return "\n".join(self.log[-n:])

    # variables
    def vr(self, name: str, type_: str) -> int:
        v = self.vars[name]
        assert v.type == type_, f"{name} is {v.type}, expected {type_}"
        return v.valueReference

    def triple(self, prefix: str) -> list[int]:
        return [self.vr(f"{prefix}.{role}", "Integer") for role in ("base.lo", "base.hi", "size")]

    def get_binary(self, prefix: str, separately: bool = False) -> bytes | None:
        if separately:
            lo, hi, size = (self.slave.getInteger([vr])[0] for vr in self.triple(prefix))
        else:
            lo, hi, size = self.slave.getInteger(self.triple(prefix))
        addr = ((hi & 0xFFFFFFFF) << 32) | (lo & 0xFFFFFFFF)
        if addr == 0 or size <= 0:
            return None
        return ctypes.string_at(addr, size)

    def get_address(self, prefix: str) -> tuple[int, int]:
        lo, hi, size = self.slave.getInteger(self.triple(prefix))
        return ((hi & 0xFFFFFFFF) << 32) | (lo & 0xFFFFFFFF), size

    def set_binary(self, prefix: str, data: bytes | None):
        if data is None:
            self._inputs.pop(prefix, None)
            self.slave.setInteger(self.triple(prefix), [0, 0, 0])
            return
        buf = ctypes.create_string_buffer(data, len(data))
        self._inputs[prefix] = buf  # keep it alive until the FMU is done with it
        addr = ctypes.addressof(buf)
        self.slave.setInteger(
            self.triple(prefix), [_signed32(addr & 0xFFFFFFFF), _signed32(addr >> 32), len(data)]
        )

    def get_bool(self, name: str) -> bool:
        return bool(self.slave.getBoolean([self.vr(name, "Boolean")])[0])

    def get_int(self, name: str) -> int:
        return self.slave.getInteger([self.vr(name, "Integer")])[0]

    def get_real(self, name: str) -> float:
        return self.slave.getReal([self.vr(name, "Real")])[0]

    def get_string(self, name: str) -> str:
        return self.slave.getString([self.vr(name, "String")])[0].decode()

    # life cycle
    def instantiate(self, mode: str | None = None):
        self.slave.instantiate(callbacks=self.callbacks, loggingOn=True)
        self.instantiated = True
        if mode is not None:
            self.slave.setString([self.vr("mode", "String")], [mode])
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()

    def handshake(self) -> svc.SensorViewConfiguration:
        """Read the request, grant it unchanged, leave Initialization Mode."""
        raw = self.get_binary("OSMPSensorViewInConfigRequest")
        assert raw, "empty OSMPSensorViewInConfigRequest\n" + self.log_tail()
        # Importers may read lo/hi/size in separate calls (osi-sensor-model-packaging#113).
        assert self.get_binary("OSMPSensorViewInConfigRequest", separately=True) == raw
        request = svc.SensorViewConfiguration.FromString(raw)
        self.set_binary("OSMPSensorViewInConfig", raw)
        # Once a Config is set, the request echoes it.
        echoed = self.get_binary("OSMPSensorViewInConfigRequest")
        assert echoed and svc.SensorViewConfiguration.FromString(echoed) == request
        self.slave.exitInitializationMode()
        # The Config buffer need only live until fmi2ExitInitializationMode returns (and the fixed
        # parameter may not be set any more).
        self._inputs.pop("OSMPSensorViewInConfig", None)
        return request

    def step(self, t: float, h: float, view: bytes | None) -> int:
        """One doStep with the given SensorView bytes (None: no input); returns the fmi2Status.
        FMPy raises FMICallException for Discard/Error/Fatal."""
        self.set_binary("OSMPSensorViewIn", view)
        return self.slave.fmi2DoStep(self.slave.component, t, h, fmi2True)

    def free(self):
        """terminate + fmi2FreeInstance + unload (once; the library stays loaded while another
        instance of the same FMU holds it)."""
        if self.freed:
            return
        self.freed = True
        try:
            if self.instantiated:
                self.slave.terminate()
        finally:
            if self.instantiated:
                self.slave.fmi2FreeInstance(self.slave.component)
                self.instantiated = False
            self.slave.freeLibrary()


# ---------------------------------------------------------------------------------------------
# The scene


def rot(roll: float, pitch: float, yaw: float):
    """OSI Rot_{yaw,pitch,roll} (local -> reference): Rz(yaw)·Ry(pitch)·Rx(roll) as rows."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    return [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]


def apply(m, v):
    return [sum(m[i][j] * v[j] for j in range(3)) for i in range(3)]


def add(a, b):
    return [x + y for x, y in zip(a, b)]


HOST_POSITION = [0.0, 0.0, 0.0]  # box centre at the origin, heading +x
HOST_DIMENSION = (4.5, 1.8, 1.4)
BBCENTER_TO_REAR = [-1.4, 0.0, -0.5]
CAR = (4.5, 1.8, 1.5)
HIDDEN_CAR = (4.0, 1.6, 1.2)


class Scene:
    """Geometry derived from the FMU's configuration request."""

    def __init__(self, request: svc.SensorViewConfiguration, range_m: float):
        self.request = request
        m = request.mounting_position
        self.mounting = m
        rear = add(HOST_POSITION, BBCENTER_TO_REAR)  # host yaw 0
        self.sensor = add(rear, [m.position.x, m.position.y, m.position.z])
        o = m.orientation
        self.r_sensor = rot(o.roll, o.pitch, o.yaw)
        self.sensor_yaw = o.yaw
        self.range = max(range_m, request.range if request.HasField("range") else 0.0)
        self.fov_h = request.field_of_view_horizontal
        sees_behind = self.fov_h / 2 >= math.pi - 1e-6
        self.visible = {FRONT_ID} | ({BEHIND_ID} if sees_behind else set())
        self.invisible = {FAR_ID, HIDDEN_ID} | (set() if sees_behind else {BEHIND_ID})
        far_az = min(math.radians(10), self.fov_h / 4)
        d = self.range + 50.0
        self.positions = {
            FRONT_ID: self.at([30.0, 0.0, 0.0]),
            BEHIND_ID: self.at([-30.0, 0.0, 0.0]),
            FAR_ID: self.at([d * math.cos(far_az), d * math.sin(far_az), 0.0]),
            HIDDEN_ID: self.at([60.0, 0.0, 0.0]),  # right behind the front car, smaller: fully hidden
        }

    def at(self, p_sensor):
        return add(self.sensor, apply(self.r_sensor, p_sensor))

    def view(self, t: float, front_offset: float = 0.0, front_speed: float = 0.0) -> sv.SensorView:
        """The scene at time t; the car ahead is `front_offset` m further away along the sensor's
        x axis and moves along it at `front_speed` m/s (its velocity in the ground truth)."""
        seconds, nanos = divmod(round(t * 1e9), 10**9)
        stamp = common.Timestamp(seconds=seconds, nanos=nanos)
        version = version_pb2.InterfaceVersion(version_major=3, version_minor=8, version_patch=0)
        Mo = obj.MovingObject

        def car(oid, dim, pos, vel=(0.0, 0.0, 0.0)):
            return Mo(
                id=common.Identifier(value=oid),
                base=common.BaseMoving(
                    dimension=common.Dimension3d(length=dim[0], width=dim[1], height=dim[2]),
                    position=common.Vector3d(x=pos[0], y=pos[1], z=pos[2]),
                    orientation=common.Orientation3d(roll=0.0, pitch=0.0, yaw=self.sensor_yaw),
                    velocity=common.Vector3d(x=vel[0], y=vel[1], z=vel[2]),
                ),
                type=Mo.TYPE_VEHICLE,
                vehicle_attributes=Mo.VehicleAttributes(
                    bbcenter_to_rear=common.Vector3d(x=-1.4, y=0.0, z=-0.4)
                ),
                vehicle_classification=Mo.VehicleClassification(type=Mo.VehicleClassification.TYPE_CAR),
                model_reference="car",
            )

        host = Mo(
            id=common.Identifier(value=HOST_ID),
            base=common.BaseMoving(
                dimension=common.Dimension3d(
                    length=HOST_DIMENSION[0], width=HOST_DIMENSION[1], height=HOST_DIMENSION[2]
                ),
                position=common.Vector3d(x=HOST_POSITION[0], y=HOST_POSITION[1], z=HOST_POSITION[2]),
                orientation=common.Orientation3d(roll=0.0, pitch=0.0, yaw=0.0),
                velocity=common.Vector3d(x=0.0, y=0.0, z=0.0),
            ),
            type=Mo.TYPE_VEHICLE,
            vehicle_attributes=Mo.VehicleAttributes(
                bbcenter_to_rear=common.Vector3d(
                    x=BBCENTER_TO_REAR[0], y=BBCENTER_TO_REAR[1], z=BBCENTER_TO_REAR[2]
                )
            ),
        )
        front = add(self.positions[FRONT_ID], apply(self.r_sensor, [front_offset, 0.0, 0.0]))
        ground_truth = gt.GroundTruth(
            version=version,
            timestamp=stamp,
            host_vehicle_id=common.Identifier(value=HOST_ID),
            moving_object=[
                host,
                car(FRONT_ID, CAR, front, apply(self.r_sensor, [front_speed, 0.0, 0.0])),
                car(BEHIND_ID, CAR, self.positions[BEHIND_ID]),
                car(FAR_ID, CAR, self.positions[FAR_ID]),
                car(HIDDEN_ID, HIDDEN_CAR, self.positions[HIDDEN_ID]),
            ],
        )
        view = sv.SensorView(
            version=version,
            timestamp=stamp,
            mounting_position=self.mounting,
            global_ground_truth=ground_truth,
            host_vehicle_id=common.Identifier(value=HOST_ID),
        )
        if self.request.HasField("sensor_id"):
            view.sensor_id.CopyFrom(self.request.sensor_id)
        # After initialization every SensorView repeats the granted configuration (OSMP).
        for c in self.request.generic_sensor_view_configuration:
            view.generic_sensor_view.add().view_configuration.CopyFrom(c)
        for c in self.request.radar_sensor_view_configuration:
            view.radar_sensor_view.add().view_configuration.CopyFrom(c)
        for c in self.request.lidar_sensor_view_configuration:
            view.lidar_sensor_view.add().view_configuration.CopyFrom(c)
        for c in self.request.camera_sensor_view_configuration:
            view.camera_sensor_view.add().view_configuration.CopyFrom(c)
        return view

    def object_at_azimuth(self, distance: float, azimuth: float) -> int | None:
        """Which scene object a sensor-frame detection direction/distance belongs to (fallback when
        a detection carries no object id): nearest object centre within 5 m."""
        p = [distance * math.cos(azimuth), distance * math.sin(azimuth)]
        best = None
        for oid, pos in self.positions.items():
            rel = [pos[i] - self.sensor[i] for i in range(3)]
            # global -> sensor: transpose of r_sensor
            local = [sum(self.r_sensor[j][i] * rel[j] for j in range(3)) for i in range(3)]
            dist = math.hypot(local[0] - p[0], local[1] - p[1])
            if dist < 5.0 and (best is None or dist < best[0]):
                best = (dist, oid)
        return best[1] if best else None


def assert_no_unknown_fields(msg, path="$"):
    unknown = UnknownFieldSet(msg)
    assert len(unknown) == 0, f"{path}: unknown fields {[u.field_number for u in unknown]}"
    for f, value in msg.ListFields():
        if f.type == FieldDescriptor.TYPE_MESSAGE:
            for i, item in enumerate(value if f.is_repeated else [value]):
                assert_no_unknown_fields(item, f"{path}.{f.name}[{i}]")


def detection_object_ids(kind: str, data: sd.SensorData, scene: Scene) -> list[int | None]:
    """The ground-truth object each feature-data detection of the sensor's kind belongs to.

    OSI 3.8.0: a detection's ``object_id`` is the ``tracking_id`` of the detected object it is
    associated to; that object's header names the ground truth. A detection of no detected object
    is placed by its direction."""
    truth = {
        o.header.tracking_id.value: (o.header.ground_truth_id[0].value if o.header.ground_truth_id else None)
        for o in list(data.moving_object) + list(data.stationary_object)
    }
    ids = []
    for block in getattr(data.feature_data, FEATURE_LIST[kind]):
        if kind == "camera":
            for det in block.detection:
                if det.HasField("object_id"):
                    assert det.object_id.value in truth, f"camera detection of no detected object {det.object_id.value}"
                    ids.append(truth[det.object_id.value])
                else:
                    first = det.first_point_index
                    pts = block.point[first : first + det.number_of_points]
                    ids.append(
                        scene.object_at_azimuth(pts[0].point.distance, pts[0].point.azimuth) if pts else None
                    )
        else:
            for det in block.detection:
                if det.HasField("object_id"):
                    assert det.object_id.value in truth, f"{kind} detection of no detected object {det.object_id.value}"
                    ids.append(truth[det.object_id.value])
                else:
                    ids.append(scene.object_at_azimuth(det.position.distance, det.position.azimuth))
    return ids


# ---------------------------------------------------------------------------------------------
# modelDescription.xml


def test_fmpy_validate_finds_no_problems(fmu_path):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu_path)) == []


def test_variable_table_contract(model_description, kind):
    table = {v.name: (v.type, v.valueReference) for v in model_description.modelVariables}
    for name, expected in CONTRACT.items():
        assert table.get(name) == expected, f"{kind}: {name} is {table.get(name)}, contract {expected}"
    assert model_description.coSimulation is not None
    assert model_description.modelExchange is None
    assert model_description.variableNamingConvention == "structured"
    assert model_description.coSimulation.canHandleVariableCommunicationStepSize
    assert not model_description.coSimulation.canBeInstantiatedOnlyOncePerProcess
    assert model_description.defaultExperiment is not None and model_description.defaultExperiment.stepSize


def test_osmp_annotations(xml_root, kind):
    marker = xml_root.findall(f"./VendorAnnotations/Tool[@name='{OSMP_TOOL}']/{OSMP_NS}osmp")
    assert len(marker) == 1
    assert marker[0].get("version") == "1.6.0" and marker[0].get("osi-version") == "3.8.0"
    variables = {sv_.get("name"): sv_ for sv_ in xml_root.findall("./ModelVariables/ScalarVariable")}
    for prefix, mime in BINARY_VARIABLES.items():
        assert prefix not in variables, f"no variable may be named {prefix}"
        attrs = set()
        for role in ("base.lo", "base.hi", "size"):
            var = variables[f"{prefix}.{role}"]
            notes = var.findall(f"./Annotations/Tool[@name='{OSMP_TOOL}']/{OSMP_NS}osmp-binary-variable")
            assert len(notes) == 1, f"{kind}: {prefix}.{role} needs exactly one OSMP annotation"
            note = notes[0]
            assert (note.get("name"), note.get("role"), note.get("mime-type")) == (prefix, role, mime)
            attrs.add((var.get("causality"), var.get("variability")))
        assert len(attrs) == 1, f"{prefix}: causality/variability differ within the triple: {attrs}"


# ---------------------------------------------------------------------------------------------
# Driving the FMU


@pytest.fixture(scope="module")
def run(kind, model_description, unzip_dir, perception_class):
    """Instantiate, handshake, 5 steps of the scene; everything copied out for the tests below."""
    slave = OsmpSlave(model_description, unzip_dir, f"{kind}_main")
    result = {"slave_log": slave.log}
    try:
        # The object-level contract below is the ideal model's; the physical models have their own
        # test (test_physical_model_in_fmpy).
        slave.instantiate(mode="ideal")
        result["range_m"] = slave.get_real("range_m")
        result["fov_h"] = slave.get_real("fov_horizontal_rad")
        result["fov_v"] = slave.get_real("fov_vertical_rad")
        result["mode"] = slave.get_string("mode")
        request = slave.handshake()
        scene = Scene(request, result["range_m"])
        result.update(request=request, scene=scene, steps=[])
        h = model_description.defaultExperiment.stepSize
        h = float(h) if h else 0.05
        previous = None
        for k in range(5):
            t = k * h
            view = scene.view(t)
            status = slave.step(t, h, view.SerializeToString())
            step = {"t": t, "view": view, "status": status}
            step["valid"] = slave.get_bool("valid")
            step["count"] = slave.get_int("count")
            step["sensor_data"] = slave.get_binary("OSMPSensorDataOut")
            step["perception"] = slave.get_binary("PerceptionDataOut")
            step["address"] = slave.get_address("OSMPSensorDataOut")
            if previous is not None:
                # OSMP double buffering: the previous output is still readable until the next doStep.
                addr, size = previous["address"]
                step["previous_still_valid"] = (
                    addr != 0 and ctypes.string_at(addr, size) == previous["sensor_data"]
                )
            result["steps"].append(step)
            previous = step
        result["perception_class"] = perception_class
    finally:
        slave.free()
    result["log"] = "\n".join(slave.log[-20:])
    return result


def decoded_steps(run):
    out = []
    for step in run["steps"]:
        assert step["sensor_data"], f"t={step['t']}: no SensorData\n{run['log']}"
        out.append((step, sd.SensorData.FromString(step["sensor_data"])))
    return out


def test_configuration_request(run, kind):
    req = run["request"]
    assert req.HasField("field_of_view_horizontal") and req.field_of_view_horizontal > 0
    assert req.HasField("field_of_view_vertical") and req.field_of_view_vertical > 0
    assert req.HasField("range") and req.range > 0
    assert req.HasField("mounting_position") and req.mounting_position.HasField("position")
    assert math.isclose(req.field_of_view_horizontal, run["fov_h"], rel_tol=1e-9)
    assert math.isclose(req.field_of_view_vertical, run["fov_v"], rel_tol=1e-9)
    assert req.range >= run["range_m"] - 1e-9
    assert (req.version.version_major, req.version.version_minor, req.version.version_patch) == (3, 8, 0)
    # The technology-specific configuration of the FMU's kind is requested.
    specific = {
        "camera": req.camera_sensor_view_configuration,
        "radar": req.radar_sensor_view_configuration,
        "lidar": req.lidar_sensor_view_configuration,
    }
    assert len(specific[kind]) >= 1
    for other, lst in specific.items():
        if other != kind:
            assert len(lst) == 0
    if kind == "lidar":
        # The default LiDAR spins: 360° FoV, so the car behind the sensor is in view.
        assert BEHIND_ID in run["scene"].visible
    assert run["mode"] == "ideal"


def test_steps_succeed_and_produce_sensor_data(run):
    for step in run["steps"]:
        assert step["status"] == fmi2OK, f"t={step['t']}: status {step['status']}\n{run['log']}"
        assert step["valid"] is True
        assert step["sensor_data"], f"t={step['t']}: no SensorData\n{run['log']}"


def test_sensor_data_header_fields(run):
    last_ts = None
    for step, data in decoded_steps(run):
        view = step["view"]
        assert_no_unknown_fields(data)
        assert (data.version.version_major, data.version.version_minor, data.version.version_patch) == (
            3,
            8,
            0,
        )
        assert data.HasField("timestamp")
        assert data.timestamp == view.timestamp, (
            f"SensorData.timestamp {data.timestamp} != SensorView's {view.timestamp}"
        )
        ts = data.timestamp.seconds + data.timestamp.nanos * 1e-9
        assert last_ts is None or ts > last_ts
        last_ts = ts
        assert data.HasField("mounting_position")
        assert data.mounting_position == view.mounting_position
        if view.HasField("sensor_id"):
            assert data.sensor_id == view.sensor_id
        assert step["count"] == len(data.moving_object) + len(data.stationary_object)


def test_detected_objects(run):
    scene = run["scene"]
    for step, data in decoded_steps(run):
        by_gt = {}
        for o in data.moving_object:
            for g in o.header.ground_truth_id:
                by_gt[g.value] = o
        for oid in scene.visible:
            assert oid in by_gt, (
                f"t={step['t']}: object {oid} not detected; got {sorted(by_gt)}\n{run['log']}"
            )
        for oid in scene.invisible:
            assert oid not in by_gt, f"t={step['t']}: object {oid} must not be detected"
        assert HOST_ID not in by_gt, "the host vehicle is not a detection"
        front = by_gt[FRONT_ID].base.position
        # Sensor frame; box centre (30 m) or nearest face (27.75 m) depending on the convention.
        assert 25.0 < front.x < 31.0 and abs(front.y) < 1.0 and abs(front.z) < 1.5, front
        if BEHIND_ID in by_gt:
            behind = by_gt[BEHIND_ID].base.position
            assert -31.0 < behind.x < -25.0 and abs(behind.y) < 1.0, behind


def test_feature_data_detections(run, kind):
    scene = run["scene"]
    for step, data in decoded_steps(run):
        blocks = getattr(data.feature_data, FEATURE_LIST[kind])
        assert len(blocks) >= 1, f"no feature_data.{FEATURE_LIST[kind]}"
        for other, field in FEATURE_LIST.items():
            if other != kind:
                assert len(getattr(data.feature_data, field)) == 0
        for block in blocks:
            assert block.header.HasField("mounting_position")
            assert block.header.mounting_position == data.mounting_position == step["view"].mounting_position
        ids = detection_object_ids(kind, data, scene)
        for oid in scene.visible:
            assert oid in ids, f"t={step['t']}: no {kind} detection of object {oid}: {ids}"
        for oid in scene.invisible:
            assert oid not in ids, f"t={step['t']}: {kind} detection of object {oid}"


def test_output_double_buffering(run):
    for step in run["steps"][1:]:
        assert step["previous_still_valid"], "the previous SensorData buffer must survive the next doStep"


def test_perception_data_out(run, kind):
    cls = run["perception_class"]
    for step, data in decoded_steps(run):
        raw = step["perception"]
        if raw is None:
            continue
        assert len(raw) > 0
        p = cls.FromString(raw)
        assert (p.osi_version.version_major, p.osi_version.version_minor, p.osi_version.version_patch) == (
            3,
            8,
            0,
        )
        assert p.extension_version == "1.0.0"
        assert p.timestamp.seconds == data.timestamp.seconds and p.timestamp.nanos == data.timestamp.nanos
        present = [name for name in ("camera", "radar", "lidar") if p.HasField(name)]
        assert present == [kind]
        assert p.model_mode == run["mode"]


def test_perception_mime_annotation(xml_root):
    variables = {v.get("name"): v for v in xml_root.findall("./ModelVariables/ScalarVariable")}
    for role in ("base.lo", "base.hi", "size"):
        note = variables[f"PerceptionDataOut.{role}"].find(
            f"./Annotations/Tool[@name='{OSMP_TOOL}']/{OSMP_NS}osmp-binary-variable"
        )
        assert note is not None and note.get("mime-type") == MIME_PERCEPTION


# ---------------------------------------------------------------------------------------------
# Robustness


def _started(model_description, unzip_dir, name) -> tuple[OsmpSlave, Scene]:
    slave = OsmpSlave(model_description, unzip_dir, name)
    slave.instantiate(mode="ideal")
    range_m = slave.get_real("range_m")
    request = slave.handshake()
    return slave, Scene(request, range_m)


def _front_detected(slave: OsmpSlave) -> tuple[bool, sd.SensorData | None]:
    raw = slave.get_binary("OSMPSensorDataOut")
    if raw is None:
        return False, None
    data = sd.SensorData.FromString(raw)
    return any(g.value == FRONT_ID for o in data.moving_object for g in o.header.ground_truth_id), data


def test_null_input_and_garbage(model_description, unzip_dir, kind):
    slave, scene = _started(model_description, unzip_dir, f"{kind}_robust")
    try:
        h = 0.05
        # No input (address 0, size 0): OK, not valid, no SensorData.
        assert slave.step(0.0, h, None) == fmi2OK, slave.log_tail()
        assert slave.get_bool("valid") is False
        assert slave.get_binary("OSMPSensorDataOut") is None
        # A good step.
        assert slave.step(h, h, scene.view(h).SerializeToString()) == fmi2OK, slave.log_tail()
        assert slave.get_bool("valid") is True and _front_detected(slave)[0]
        # Size 0 with a non-null address: also "no input".
        buf = ctypes.create_string_buffer(b"\x08\x01", 2)
        addr = ctypes.addressof(buf)
        slave.slave.setInteger(
            slave.triple("OSMPSensorViewIn"), [_signed32(addr & 0xFFFFFFFF), _signed32(addr >> 32), 0]
        )
        assert slave.slave.fmi2DoStep(slave.slave.component, 2 * h, h, fmi2True) == fmi2OK
        assert slave.get_bool("valid") is False
        # Garbage bytes: the step returns (Warning allowed; FMPy raises on Discard/Error/Fatal) ...
        rng = random.Random(1234)
        for i in range(3):
            garbage = bytes(rng.randrange(256) for _ in range(997 + i))
            status = slave.step((3 + i) * h, h, garbage)
            assert status in (fmi2OK, fmi2Warning), status
            assert slave.get_bool("valid") is False
        # ... and the next good step works.
        t = 6 * h
        assert slave.step(t, h, scene.view(t).SerializeToString()) == fmi2OK, slave.log_tail()
        assert slave.get_bool("valid") is True
        detected, data = _front_detected(slave)
        assert detected and data.timestamp == scene.view(t).timestamp
    finally:
        slave.free()


def test_two_instances_in_one_process(model_description, unzip_dir, kind):
    a, scene_a = _started(model_description, unzip_dir, f"{kind}_a")
    b, scene_b = _started(model_description, unzip_dir, f"{kind}_b")
    try:
        h = 0.05
        for k in range(3):
            t = k * h
            assert a.step(t, h, scene_a.view(t).SerializeToString()) == fmi2OK, a.log_tail()
            # Instance b sees its front car 10 m further away.
            assert b.step(t, h, scene_b.view(t, front_offset=10.0).SerializeToString()) == fmi2OK, (
                b.log_tail()
            )
            _, data_a = _front_detected(a)
            _, data_b = _front_detected(b)
            xa = next(
                o.base.position.x
                for o in data_a.moving_object
                if o.header.ground_truth_id[0].value == FRONT_ID
            )
            xb = next(
                o.base.position.x
                for o in data_b.moving_object
                if o.header.ground_truth_id[0].value == FRONT_ID
            )
            assert 9.0 < xb - xa < 11.0, (xa, xb)
        a.free()
        # b keeps working after a is gone (the library stays loaded for b).
        t = 3 * h
        assert b.step(t, h, scene_b.view(t).SerializeToString()) == fmi2OK
        assert _front_detected(b)[0]
    finally:
        a.free()
        b.free()


def test_simulate_fmu_without_inputs(fmu_path):
    # No input connected: every step sees address/size 0 and must succeed without output.
    result = fmpy.simulate_fmu(str(fmu_path), stop_time=0.2)
    assert len(result) >= 2
    assert "valid" in result.dtype.names
    assert not any(result["valid"])
    assert all(result["OSMPSensorDataOut.size"] == 0)


# ---------------------------------------------------------------------------------------------
# The physical models


PHYSICAL_KINDS = ("camera", "radar", "lidar")


def test_default_mode(model_description, kind):
    mode = next(v for v in model_description.modelVariables if v.name == "mode")
    assert mode.start == ("physical" if kind in PHYSICAL_KINDS else "ideal")


def test_physical_model_in_fmpy(kind, model_description, unzip_dir, perception_class):
    """The physical camera / radar / LiDAR model in FMPy: every step OK, SensorData decodes with the
    official bindings (no unknown fields), feature-data detections on the car ahead and none on the car
    out of range, raw perception output in the extension, and the car ahead recognised (and tracked).
    Detection is drawn per frame with the model's detection probability (≈ 0.97 for the car ahead), so
    the car ahead must be detected in at least 6 of the 8 frames, not in every one."""
    if kind not in PHYSICAL_KINDS:
        pytest.skip(f"no physical {kind} model yet")
    slave = OsmpSlave(model_description, unzip_dir, f"{kind}_physical")
    try:
        slave.instantiate(mode="physical")
        range_m = slave.get_real("range_m")
        request = slave.handshake()
        scene = Scene(request, range_m)
        h = float(model_description.defaultExperiment.stepSize)
        tracked = False
        detected, recognised = 0, 0
        for k in range(8):
            t = k * h
            # The car ahead recedes at 3 m/s: a radar tracker confirms moving targets (parked cars
            # are stationary clutter to it).
            view = scene.view(t, front_offset=3.0 * t, front_speed=3.0)
            status = slave.step(t, h, view.SerializeToString())
            assert status == fmi2OK, f"t={t}: status {status}\n{slave.log_tail()}"
            assert slave.get_bool("valid") is True
            raw = slave.get_binary("OSMPSensorDataOut")
            assert raw, f"t={t}: no SensorData\n{slave.log_tail()}"
            data = sd.SensorData.FromString(raw)
            assert_no_unknown_fields(data)
            assert data.timestamp == view.timestamp
            ids = detection_object_ids(kind, data, scene)
            detected += FRONT_ID in ids
            assert FAR_ID not in ids, f"t={t}: {kind} detection on the car beyond the range"
            # (No assertion on the "hidden" car: it is hidden behind the front car's box, but the
            # car mesh is not a box, and the LiDAR sees parts of it past the front car's roof.)
            p = perception_class.FromString(slave.get_binary("PerceptionDataOut"))
            assert p.model_mode == "physical"
            if kind == "camera":
                assert p.camera.image and all(img.width_px > 0 and img.data for img in p.camera.image)
                recognised += any(o.object_id == FRONT_ID and o.type_code == 2 for o in p.camera.object)
            elif kind == "lidar":
                n = len(p.lidar.x_m)
                assert n > 100 and len(p.lidar.intensity) == n and len(p.lidar.timestamp_ns) == n
                assert p.lidar.pulses_fired >= n // 2
            else:
                assert len(p.radar.peak) >= 1
                assert p.radar.waveform.bandwidth_hz > 0
            gt_ids = {g.value for o in data.moving_object for g in o.header.ground_truth_id}
            tracked = tracked or FRONT_ID in gt_ids
            assert HOST_ID not in gt_ids
        assert detected >= 6, f"{kind}: the car ahead detected in {detected} of 8 frames"
        if kind == "camera":
            assert recognised >= 6, f"camera: the car ahead recognised in {recognised} of 8 frames"
        assert tracked, f"the car ahead was never reported as a tracked object\n{slave.log_tail()}"
    finally:
        slave.free()
