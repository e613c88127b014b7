"""Wire compatibility of osiris' OSI 3.8.0 subset (proto/osi3/*.proto, prost types) with the official
implementation, PyPI `osi-python` 3.8.0 (the `osi3` package).

(a) Descriptor diff, compile-free: our FileDescriptorSet (`osiris_proto::FILE_DESCRIPTOR_SET`, written
    by `osi_wire descriptor-set`) against osi3's descriptors: names, numbers, types, labels,
    packedness, enum values; fields we omit are listed and must have a type outside our subset.
(b) A rich SensorView serialized by osi3 is decoded by the prost types (`osi_wire decode`) and the
    JSON dump is compared value by value with `MessageToDict`; the prost re-encoding is compared
    byte by byte with osi3's serialization of the same message minus the fields outside our subset.
(c) A rich SensorData built in Rust (`osi_wire encode-sensor-data`) is decoded by osi3 and compared
    with the same message built here, value by value and byte by byte.
(d) Golden vectors: small messages built in Rust (`osi_wire golden`) and here serialize identically.

The Rust builders live in examples/osi_wire.rs; change both sides together.
"""

from __future__ import annotations

import base64
import importlib
import json
import math
import pkgutil

import osi3
import pytest
from google.protobuf import descriptor_pb2, descriptor_pool
from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.json_format import MessageToDict
from google.protobuf.unknown_fields import UnknownFieldSet
from osi3 import osi_common_pb2 as common
from osi3 import osi_detectedobject_pb2 as detobj
from osi3 import osi_environment_pb2 as env
from osi3 import osi_featuredata_pb2 as feat
from osi3 import osi_groundtruth_pb2 as gt
from osi3 import osi_hostvehicledata_pb2 as hvd
from osi3 import osi_lane_pb2 as lane
from osi3 import osi_logicaldetectiondata_pb2 as logical
from osi3 import osi_object_pb2 as obj
from osi3 import osi_referenceline_pb2 as refline
from osi3 import osi_sensordata_pb2 as sd
from osi3 import osi_sensorspecific_pb2 as spec
from osi3 import osi_sensorview_pb2 as sv
from osi3 import osi_sensorviewconfiguration_pb2 as svc
from osi3 import osi_detectedlane_pb2 as dlane
from osi3 import osi_detectedroadmarking_pb2 as drm
from osi3 import osi_detectedtrafficlight_pb2 as dtl
from osi3 import osi_detectedtrafficsign_pb2 as dts
from osi3 import osi_roadmarking_pb2 as rmark
from osi3 import osi_trafficlight_pb2 as tlight
from osi3 import osi_trafficsign_pb2 as tsign
from osi3 import osi_version_pb2 as version_pb2

# Every official module, so the default pool holds all 3.8.0 descriptors.
for _m in pkgutil.iter_modules(osi3.__path__):
    if _m.name.endswith("_pb2"):
        importlib.import_module(f"osi3.{_m.name}")

OFFICIAL = descriptor_pool.Default()
U64_MAX = 2**64 - 1
U32_MAX = 2**32 - 1


# ---------------------------------------------------------------------------------------------
# Fixtures and helpers


@pytest.fixture(scope="session")
def our_fds(osi_wire, tmp_path_factory) -> descriptor_pb2.FileDescriptorSet:
    path = tmp_path_factory.mktemp("fds") / "osiris.pb"
    osi_wire.run("descriptor-set", path)
    return descriptor_pb2.FileDescriptorSet.FromString(path.read_bytes())


@pytest.fixture(scope="session")
def our_pool(our_fds) -> descriptor_pool.DescriptorPool:
    pool = descriptor_pool.DescriptorPool()
    for f in our_fds.file:
        pool.Add(f)
    return pool


def _walk_messages(descs):
    for md in descs:
        yield md
        yield from _walk_messages(md.nested_types)


def our_osi3_files(our_fds, our_pool):
    return [our_pool.FindFileByName(f.name) for f in our_fds.file if f.package == "osi3"]


def our_messages(our_fds, our_pool):
    for fd in our_osi3_files(our_fds, our_pool):
        yield from _walk_messages(fd.message_types_by_name.values())


def our_enums(our_fds, our_pool):
    for fd in our_osi3_files(our_fds, our_pool):
        yield from fd.enum_types_by_name.values()
        for md in _walk_messages(fd.message_types_by_name.values()):
            yield from md.enum_types


def _type_name(f: FieldDescriptor) -> str | None:
    if f.message_type is not None:
        return f.message_type.full_name
    if f.enum_type is not None:
        return f.enum_type.full_name
    return None


def project(msg, our_pool, dropped: set[str]):
    """Copy of an official message without the fields outside our subset (recursively); the
    dropped fields are added to `dropped` as `<message full name>.<field name>`."""
    out = type(msg)()
    out.CopyFrom(msg)
    _project_in_place(out, our_pool, dropped)
    return out


def _project_in_place(msg, our_pool, dropped):
    ours = our_pool.FindMessageTypeByName(msg.DESCRIPTOR.full_name)
    for f, value in msg.ListFields():
        if f.number not in ours.fields_by_number:
            dropped.add(f"{msg.DESCRIPTOR.full_name}.{f.name}")
            msg.ClearField(f.name)
        elif f.type == FieldDescriptor.TYPE_MESSAGE:
            for item in value if f.is_repeated else [value]:
                _project_in_place(item, our_pool, dropped)


def to_dict(msg) -> dict:
    return MessageToDict(msg, preserving_proto_field_name=True, use_integers_for_enums=True)


def json_diff(actual, expected, path="$") -> list[str]:
    """Exact, type-aware comparison of two JSON-like values; returns the differences by path."""
    if isinstance(expected, dict):
        if not isinstance(actual, dict):
            return [f"{path}: expected an object, got {actual!r}"]
        out = []
        for k in sorted(set(actual) | set(expected)):
            if k not in actual:
                out.append(f"{path}.{k}: missing (expected {expected[k]!r})")
            elif k not in expected:
                out.append(f"{path}.{k}: unexpected {actual[k]!r}")
            else:
                out += json_diff(actual[k], expected[k], f"{path}.{k}")
        return out
    if isinstance(expected, list):
        if not isinstance(actual, list) or len(actual) != len(expected):
            return [f"{path}: expected {expected!r}, got {actual!r}"]
        return [d for i, (a, e) in enumerate(zip(actual, expected)) for d in json_diff(a, e, f"{path}[{i}]")]
    if isinstance(expected, bool) or isinstance(actual, bool):
        ok = type(actual) is type(expected) and actual == expected
    elif isinstance(expected, float) and isinstance(actual, (int, float)):
        # Exact: both sides print the shortest representation that round-trips.
        ok = float(actual) == expected and math.copysign(1, float(actual)) == math.copysign(1, expected)
    else:
        ok = type(actual) is type(expected) and actual == expected
    return [] if ok else [f"{path}: expected {expected!r}, got {actual!r}"]


def assert_no_unknown_fields(msg, path="$"):
    unknown = UnknownFieldSet(msg)
    assert len(unknown) == 0, f"{path}: unknown fields {[u.field_number for u in unknown]}"
    for f, value in msg.ListFields():
        if f.type == FieldDescriptor.TYPE_MESSAGE:
            for i, item in enumerate(value if f.is_repeated else [value]):
                assert_no_unknown_fields(item, f"{path}.{f.name}[{i}]")


def message_paths(msg, prefix=""):
    """All present field paths of a message (to check the test messages really are rich)."""
    for f, value in msg.ListFields():
        yield f"{prefix}{f.name}"
        if f.type == FieldDescriptor.TYPE_MESSAGE:
            for item in value if f.is_repeated else [value]:
                yield from message_paths(item, f"{prefix}{f.name}.")


# ---------------------------------------------------------------------------------------------
# (a) descriptor diff


def test_our_files_mirror_official_files(our_fds, our_pool):
    osi_files = [f for f in our_fds.file if f.package == "osi3"]
    assert len(osi_files) >= 10
    for f in our_fds.file:
        if f.package == "osi3":
            assert f.name.startswith("osi3/"), f.name
            assert f.syntax in ("", "proto2"), f"{f.name}: syntax {f.syntax!r}"
            official = OFFICIAL.FindFileByName(f.name)  # same file names as the standard
            assert official.package == "osi3"
            # Every message of our file is defined in the same official file.
            ours = our_pool.FindFileByName(f.name)
            for name in ours.message_types_by_name:
                assert name in official.message_types_by_name, f"{f.name}: {name} not in the official file"
            for name in ours.enum_types_by_name:
                assert name in official.enum_types_by_name, f"{f.name}: enum {name} not in the official file"
        else:
            # Only our extension package and the imported descriptor.proto live outside osi3.
            assert f.package in ("osiris.perception", "google.protobuf"), f.name
            assert not f.name.startswith("osi3/"), f.name


def test_interface_version_option_and_extension(our_fds, our_pool):
    ours = next(f for f in our_fds.file if f.name == "osi3/osi_version.proto")
    official_ext = version_pb2.current_interface_version
    (ext,) = ours.extension
    assert ext.name == official_ext.name == "current_interface_version"
    assert ext.number == official_ext.number == 81000
    assert ext.extendee == ".google.protobuf.FileOptions"
    assert ext.type_name == ".osi3.InterfaceVersion"
    assert ext.label == descriptor_pb2.FieldDescriptorProto.LABEL_OPTIONAL
    # Parsed with the official extension registered: the file option says 3.8.0, like osi3's.
    v = ours.options.Extensions[official_ext]
    assert (v.version_major, v.version_minor, v.version_patch) == (3, 8, 0)
    ov = version_pb2.DESCRIPTOR.GetOptions().Extensions[official_ext]
    assert (ov.version_major, ov.version_minor, ov.version_patch) == (3, 8, 0)


def test_messages_and_fields_match_official(our_fds, our_pool):
    problems = []
    checked_fields = 0
    messages = list(our_messages(our_fds, our_pool))
    assert len(messages) > 50
    for md in messages:
        try:
            om = OFFICIAL.FindMessageTypeByName(md.full_name)
        except KeyError:
            problems.append(f"{md.full_name}: no such official message")
            continue
        if md.oneofs:
            problems.append(f"{md.full_name}: has oneofs (OSI has none)")
        for f in md.fields:
            where = f"{md.full_name}.{f.name} = {f.number}"
            of = om.fields_by_number.get(f.number)
            if of is None:
                problems.append(f"{where}: no official field with this number")
                continue
            checked_fields += 1
            if of.name != f.name:
                problems.append(f"{where}: official name is {of.name}")
            if of.type != f.type:
                problems.append(f"{where}: type {f.type}, official {of.type}")
            if _type_name(of) != _type_name(f):
                problems.append(f"{where}: type name {_type_name(f)}, official {_type_name(of)}")
            if of.is_repeated != f.is_repeated or of.is_required != f.is_required:
                problems.append(f"{where}: label differs (repeated {f.is_repeated}/{of.is_repeated})")
            if f.is_required:
                problems.append(f"{where}: required (OSI has no required fields)")
            if not f.is_repeated and not (f.has_presence and of.has_presence):
                problems.append(f"{where}: no explicit presence (must be proto2 optional)")
            if f.is_packed or of.is_packed:
                problems.append(f"{where}: packed (ours {f.is_packed}, official {of.is_packed})")
            if f.has_default_value or of.has_default_value:
                problems.append(f"{where}: has a default value")
            if f.containing_oneof is not None:
                problems.append(f"{where}: in a oneof")
        # Packedness straight from the raw descriptor too: no [packed=...] option anywhere.
        raw = descriptor_pb2.DescriptorProto()
        md.CopyToProto(raw)
        for fp in raw.field:
            if fp.options.HasField("packed") or fp.proto3_optional:
                problems.append(f"{md.full_name}.{fp.name}: packed option / proto3_optional set")
    assert not problems, "descriptor differences:\n" + "\n".join(problems)
    assert checked_fields > 400


def test_repeated_scalars_are_unpacked(our_fds, our_pool):
    """OSI is proto2: repeated scalars are unpacked on the wire (e.g. LidarSensorViewConfiguration
    .timings). Explicitly list the ones we define so none slips through."""
    repeated_scalars = []
    for md in our_messages(our_fds, our_pool):
        for f in md.fields:
            if f.is_repeated and f.type not in (FieldDescriptor.TYPE_MESSAGE, FieldDescriptor.TYPE_GROUP):
                repeated_scalars.append(f"{md.full_name}.{f.name}")
                assert not f.is_packed, f"{md.full_name}.{f.name} is packed"
                of = OFFICIAL.FindMessageTypeByName(md.full_name).fields_by_number[f.number]
                assert not of.is_packed
    assert "osi3.LidarSensorViewConfiguration.timings" in repeated_scalars
    assert "osi3.CameraSensorViewConfiguration.channel_format" in repeated_scalars
    assert "osi3.StationaryObject.Classification.assigned_lane_percentage" in repeated_scalars


def test_enums_match_official(our_fds, our_pool):
    problems = []
    aliases_left_out = []
    enums = list(our_enums(our_fds, our_pool))
    assert len(enums) > 30
    for ed in enums:
        try:
            oe = OFFICIAL.FindEnumTypeByName(ed.full_name)
        except KeyError:
            problems.append(f"{ed.full_name}: no such official enum")
            continue
        for v in ed.values:
            ov = oe.values_by_name.get(v.name)
            if ov is None:
                problems.append(f"{ed.full_name}.{v.name}: no official value with this name")
            elif ov.number != v.number:
                problems.append(f"{ed.full_name}.{v.name} = {v.number}: official number {ov.number}")
        our_numbers = {v.number for v in ed.values}
        for ov in oe.values:
            if ov.name not in ed.values_by_name:
                if ov.number in our_numbers:
                    aliases_left_out.append(f"{ed.full_name}.{ov.name} = {ov.number}")
                else:
                    problems.append(f"{ed.full_name}: official value {ov.name} = {ov.number} missing")
    assert not problems, "enum differences:\n" + "\n".join(problems)
    # prost keeps one name per number: exactly the aliases of the standard are left out.
    assert sorted(aliases_left_out) == sorted(
        [
            "osi3.MovingObject.VehicleClassification.Type.TYPE_MEDIUM_CAR = 4",
            "osi3.MovingObject.VehicleClassification.Type.TYPE_VAN = 6",
            "osi3.MovingObject.VehicleClassification.Type.TYPE_MOTORCYCLE = 10",
            "osi3.StationaryObject.Classification.Material.MATERIAL_GLAS = 7",
            "osi3.StationaryObject.Classification.Color.COLOR_GREY = 9",
            "osi3.CameraDetection.Color.COLOR_GREY = 3",
        ]
    ), aliases_left_out


def test_omitted_official_fields_are_outside_the_subset(our_fds, our_pool, capsys):
    """Informational summary of the official fields our subset leaves out (decoders skip them);
    an omission is only allowed where the field's message/enum type is not in our subset."""
    our_types = {md.full_name for md in our_messages(our_fds, our_pool)}
    our_types |= {ed.full_name for ed in our_enums(our_fds, our_pool)}
    omitted, problems = [], []
    for md in our_messages(our_fds, our_pool):
        om = OFFICIAL.FindMessageTypeByName(md.full_name)
        for of in om.fields:
            if of.number in md.fields_by_number:
                continue
            tn = _type_name(of)
            omitted.append(f"{md.full_name}.{of.name} = {of.number} ({tn or 'scalar'})")
            if tn is None:
                problems.append(f"{md.full_name}.{of.name}: scalar field omitted")
            elif tn in our_types:
                problems.append(f"{md.full_name}.{of.name}: omitted although {tn} is in our subset")
    with capsys.disabled():
        print(f"\n[osi subset] {len(omitted)} official fields outside the osiris subset:")
        for line in omitted:
            print(f"  {line}")
    assert not problems, "\n".join(problems)


def test_top_level_messages_are_defined(our_pool):
    for name in (
        "SensorView",
        "SensorData",
        "SensorViewConfiguration",
        "GroundTruth",
        "FeatureData",
        "DetectedMovingObject",
        "DetectedStationaryObject",
        "LogicalDetectionData",
    ):
        assert our_pool.FindMessageTypeByName(f"osi3.{name}").full_name == f"osi3.{name}"
    perception = our_pool.FindMessageTypeByName("osiris.perception.PerceptionData")
    assert perception.file.package == "osiris.perception"


# ---------------------------------------------------------------------------------------------
# Message builders (osi3 side)


def v3(x, y, z):
    return common.Vector3d(x=x, y=y, z=z)


def v2(x, y):
    return common.Vector2d(x=x, y=y)


def o3(roll, pitch, yaw):
    return common.Orientation3d(roll=roll, pitch=pitch, yaw=yaw)


def d3(length, width, height):
    return common.Dimension3d(length=length, width=width, height=height)


def sph(distance, azimuth, elevation):
    return common.Spherical3d(distance=distance, azimuth=azimuth, elevation=elevation)


def ts(seconds, nanos):
    return common.Timestamp(seconds=seconds, nanos=nanos)


def ident(value):
    return common.Identifier(value=value)


def mp(position, orientation):
    return common.MountingPosition(position=position, orientation=orientation)


def version():
    return version_pb2.InterfaceVersion(version_major=3, version_minor=8, version_patch=0)


UNICODE = 'Fahrzeug Ü-Straße/車両/🚗 \u00e9\u0301 "quoted" \\ \n'


PI_F = 3.141592653589793


def rich_sensor_view() -> sv.SensorView:
    """A SensorView with every kind of field of the subset set, plus fields outside it."""
    MO = obj.MovingObject
    VC = MO.VehicleClassification
    LS = VC.LightState
    SC = obj.StationaryObject.Classification
    mount = mp(v3(1.4, 0.0, 1.9), o3(0.0, -0.0349, 3.14159))
    mount_rmse = mp(v3(0.01, 0.01, 0.01), o3(0.001, 0.001, 0.001))
    ext_ref = common.ExternalReference(
        reference="https://example.org/scenario.xosc",
        type="net.asam.openscenario",
        identifier=["Ego", UNICODE, ""],
    )

    host = MO(
        id=ident(0),
        base=common.BaseMoving(
            dimension=d3(4.5, 1.8, 1.4),
            position=v3(-1234.5, 987.25, 0.7),
            orientation=o3(0.0, 0.0, -1.5),
            velocity=v3(-13.9, 0.1, 0.0),
            acceleration=v3(-0.5, 0.0, 0.0),
            orientation_rate=o3(0.0, 0.0, -0.01),
            orientation_acceleration=o3(0.0, 0.0, 0.001),
            base_polygon=[v2(2.25, 0.9), v2(-2.25, 0.9), v2(-2.25, -0.9), v2(2.25, -0.9)],
            bounding_box_section=[
                common.BoundingBox(
                    dimension=d3(0.2, 0.25, 0.15),
                    position=v3(0.9, 1.0, 0.3),
                    orientation=o3(0, 0, 0),
                    contained_object_type=common.BoundingBox.TYPE_SIDE_MIRROR,
                    model_reference="mirror_L.glb",
                )
            ],
        ),
        type=MO.TYPE_VEHICLE,
        assigned_lane_id=[ident(0), ident(1)],
        vehicle_attributes=MO.VehicleAttributes(
            driver_id=ident(0),
            radius_wheel=0.33,
            number_wheels=4,
            bbcenter_to_rear=v3(-1.4, 0.0, -0.4),
            bbcenter_to_front=v3(1.6, 0.0, -0.4),
            ground_clearance=0.15,
            wheel_data=[
                MO.VehicleAttributes.WheelData(
                    axle=0,
                    index=0,
                    position=v3(1.4, 0.8, -0.4),
                    wheel_radius=0.33,
                    rim_radius=0.2,
                    width=0.22,
                    orientation=o3(0, 0, 0.05),
                    rotation_rate=float("nan"),
                    model_reference=UNICODE,
                    friction_coefficient=1.0,
                )
            ],
            steering_wheel_angle=-0.05,
        ),
        vehicle_classification=VC(
            type=VC.TYPE_CAR,
            light_state=LS(
                indicator_state=LS.INDICATOR_STATE_LEFT,
                front_fog_light=LS.GENERIC_LIGHT_STATE_OFF,
                rear_fog_light=LS.GENERIC_LIGHT_STATE_UNKNOWN,
                head_light=LS.GENERIC_LIGHT_STATE_ON,
                high_beam=LS.GENERIC_LIGHT_STATE_OFF,
                reversing_light=LS.GENERIC_LIGHT_STATE_OFF,
                brake_light_state=LS.BRAKE_LIGHT_STATE_NORMAL,
                license_plate_illumination_rear=LS.GENERIC_LIGHT_STATE_ON,
                emergency_vehicle_illumination=LS.GENERIC_LIGHT_STATE_FLASHING_BLUE_AND_RED,
                service_vehicle_illumination=LS.GENERIC_LIGHT_STATE_OTHER,
                tail_light=LS.GENERIC_LIGHT_STATE_ON,
            ),
            has_trailer=False,
            trailer_id=ident(U64_MAX - 1),
            role=VC.ROLE_POLICE,
        ),
        model_reference=UNICODE,
        future_trajectory=[
            common.StatePoint(
                timestamp=ts(-1, 999_999_999), position=v3(-1, -2, -3), orientation=o3(0, 0, -3.0)
            )
        ],
        moving_object_classification=MO.MovingObjectClassification(
            assigned_lane_id=[ident(0)],
            assigned_lane_percentage=[100.0],
            logical_lane_assignment=[
                common.LogicalLaneAssignment(
                    assigned_lane_id=ident(9), s_position=-12.5, t_position=0.0, angle_to_lane=-0.1
                )
            ],
        ),
        source_reference=[ext_ref],
        color_description=common.ColorDescription(
            rgb=common.ColorRGB(red=0.1, green=0.2, blue=0.3),
            hsv=common.ColorHSV(hue=210.0, saturation=0.5, value=0.3),
        ),
    )
    pedestrian = MO(
        id=ident(U64_MAX - 1),
        base=common.BaseMoving(
            dimension=d3(0.3, 0.5, 1.8), position=v3(25.0, -3.0, 0.9), orientation=o3(0, 0, 1.57)
        ),
        type=MO.TYPE_PEDESTRIAN,
        pedestrian_attributes=MO.PedestrianAttributes(
            bbcenter_to_root=v3(0.0, 0.0, -0.1),
            skeleton_bone=[
                MO.PedestrianAttributes.Bone(
                    type=MO.PedestrianAttributes.Bone.TYPE_ROOT,
                    position=v3(0, 0, 1.0),
                    orientation=o3(0, 0, 0),
                    length=0.1,  # float (32-bit): printed as the shortest f32 repr
                    missing=False,
                    velocity=v3(0.5, 0, 0),
                    orientation_rate=o3(0, 0, 0),
                ),
                MO.PedestrianAttributes.Bone(
                    type=MO.PedestrianAttributes.Bone.TYPE_HEAD, length=1.7, missing=True
                ),
            ],
        ),
    )
    car = MO(
        id=ident(42),
        base=common.BaseMoving(
            dimension=d3(4.6, 1.85, 1.45),
            position=v3(30.0, 0.0, 0.7),
            orientation=o3(0, 0, 0),
            velocity=v3(-2.5, 0, 0),
        ),
        type=MO.TYPE_VEHICLE,
        vehicle_attributes=MO.VehicleAttributes(bbcenter_to_rear=v3(-1.4, 0, -0.3)),
        vehicle_classification=VC(type=VC.TYPE_LAND_VEHICLE, role=VC.ROLE_UNKNOWN),
        model_reference="",
    )
    pole = obj.StationaryObject(
        id=ident(1001),
        base=common.BaseStationary(
            dimension=d3(0.3, 0.3, 2.0),
            position=v3(40.0, -6.0, 1.0),
            orientation=o3(0, 0, 0),
            base_polygon=[v2(0.15, 0.15), v2(-0.15, 0.15), v2(-0.15, -0.15)],
            bounding_box_section=[
                common.BoundingBox(contained_object_type=common.BoundingBox.TYPE_BASE_STRUCTURE)
            ],
        ),
        classification=SC(
            type=SC.TYPE_EMITTING_STRUCTURE,
            material=SC.MATERIAL_GLAS,  # alias of MATERIAL_GLASS = 7
            density=SC.DENSITY_SOLID,
            color=SC.COLOR_GREY,  # alias of COLOR_GRAY = 9
            emitting_structure_attribute=SC.EmittingStructureAttribute(
                wavelength_data=[common.WavelengthData(start=380e-9, end=780e-9, samples_number=41)],
                emitted_spatial_signal_strength=[
                    common.SpatialSignalStrength(
                        horizontal_angle=-0.5, vertical_angle=0.1, signal_strength=-30.0
                    )
                ],
            ),
            assigned_lane_id=[ident(0), ident(5)],
            assigned_lane_percentage=[0.0, 33.3, -0.0],
            logical_lane_assignment=[common.LogicalLaneAssignment(assigned_lane_id=ident(0))],
        ),
        model_reference="pole.glb",
        source_reference=[ext_ref, common.ExternalReference()],
        color_description=common.ColorDescription(
            grey=common.ColorGrey(grey=0.5),
            rgbir=common.ColorRGBIR(red=0.1, green=0.1, blue=0.1, infrared=0.9),
            luv=common.ColorLUV(luminance=50, u=-10, v=10),
            cmyk=common.ColorCMYK(cyan=0, magenta=0, yellow=0, key=1),
        ),
    )
    boundary = lane.LaneBoundary(
        id=ident(10),
        boundary_line=[
            lane.LaneBoundary.BoundaryPoint(
                position=v3(0, 1.75, 0),
                width=0.15,
                height=0.0,
                dash=lane.LaneBoundary.BoundaryPoint.DASH_START,
            ),
            lane.LaneBoundary.BoundaryPoint(
                position=v3(100, 1.75, 0), width=0.15, dash=lane.LaneBoundary.BoundaryPoint.DASH_END
            ),
        ],
        classification=lane.LaneBoundary.Classification(
            type=lane.LaneBoundary.Classification.TYPE_DASHED_LINE,
            color=lane.LaneBoundary.Classification.COLOR_WHITE,
            limiting_structure_id=[ident(1001)],
        ),
        source_reference=[ext_ref],
        color_description=common.ColorDescription(grey=common.ColorGrey(grey=1.0)),
    )
    LC = lane.Lane.Classification
    ego_lane = lane.Lane(
        id=ident(0),
        classification=LC(
            type=LC.TYPE_DRIVING,
            is_host_vehicle_lane=True,
            centerline=[v3(0, 0, 0), v3(50, 0.5, 0.1), v3(100, 1.5, -0.2)],
            centerline_is_driving_direction=False,
            left_adjacent_lane_id=[ident(1)],
            lane_pairing=[LC.LanePairing(antecessor_lane_id=ident(2), successor_lane_id=ident(3))],
            right_lane_boundary_id=[ident(11)],
            left_lane_boundary_id=[ident(10)],
            free_lane_boundary_id=[ident(0)],
            road_condition=LC.RoadCondition(
                surface_temperature=268.15,
                surface_water_film=0.0,
                surface_freezing_point=273.15,
                surface_ice=0.5,
                surface_roughness=1.5,
                surface_texture=0.001,
            ),
            subtype=LC.SUBTYPE_NORMAL,
        ),
        source_reference=[ext_ref],
    )
    E = env.EnvironmentalConditions
    conditions = E(
        ambient_illumination=E.AMBIENT_ILLUMINATION_LEVEL5,
        time_of_day=E.TimeOfDay(seconds_since_midnight=0),
        unix_timestamp=-1_700_000_000,
        atmospheric_pressure=101325.0,
        temperature=253.15,
        relative_humidity=0.0,
        precipitation=E.PRECIPITATION_HEAVY,
        fog=E.FOG_MIST,
        source_reference=[ext_ref],
        clouds=E.CloudLayer(fractional_cloud_cover=E.CloudLayer.FRACTIONAL_CLOUD_COVER_SKY_OBSCURED),
        wind=E.Wind(origin_direction=-3.0, speed=12.5),
        sun=E.Sun(azimuth=3.0, elevation=-0.2, intensity=float("inf")),
    )
    TS = tsign.TrafficSign
    MSC = TS.MainSign.Classification
    SSC = TS.SupplementarySign.Classification
    speed_value = tsign.TrafficSignValue(value=50.0, value_unit=tsign.TrafficSignValue.UNIT_KILOMETER_PER_HOUR, text="50")
    traffic_sign = TS(
        id=ident(77),
        main_sign=TS.MainSign(
            base=common.BaseStationary(dimension=d3(0.02, 0.6, 0.6), position=v3(40.0, -4.5, 2.3), orientation=o3(0.0, 0.0, 3.1)),
            classification=MSC(
                variability=TS.VARIABILITY_FIXED,
                type=MSC.TYPE_SPEED_LIMIT_BEGIN,
                value=speed_value,
                direction_scope=MSC.DIRECTION_SCOPE_NO_DIRECTION,
                assigned_lane_id=[ident(1), ident(U64_MAX)],
                vertically_mirrored=False,
                is_out_of_service=False,
                country="DE",
                country_revision="2017",
                code="274",
                sub_code="50",
            ),
            model_reference="",
        ),
        supplementary_sign=[
            TS.SupplementarySign(
                base=common.BaseStationary(dimension=d3(0.02, 0.6, 0.33), position=v3(40.0, -4.5, 1.8)),
                classification=SSC(
                    variability=TS.VARIABILITY_FIXED,
                    type=SSC.TYPE_TIME,
                    value=[tsign.TrafficSignValue(value=7.0, value_unit=tsign.TrafficSignValue.UNIT_HOUR)],
                    is_out_of_service=True,
                    arrow=[SSC.Arrow(lane_id=[ident(2)], direction=[SSC.Arrow.DIRECTION_DIRECT_0_DEG])],
                ),
            )
        ],
    )
    TLC = tlight.TrafficLight.Classification
    traffic_light = tlight.TrafficLight(
        id=ident(78),
        base=common.BaseStationary(dimension=d3(0.05, 0.2, 0.2), position=v3(60.0, 3.0, 5.5), orientation=o3(0.0, 0.0, -PI_F)),
        classification=TLC(
            color=TLC.COLOR_RED,
            icon=TLC.ICON_ARROW_LEFT,
            mode=TLC.MODE_COUNTING,
            counter=0.0,
            assigned_lane_id=[ident(0)],
            is_out_of_service=False,
        ),
        model_reference="osiris:traffic_light",
    )
    RMC = rmark.RoadMarking.Classification
    road_marking = rmark.RoadMarking(
        id=ident(79),
        base=common.BaseStationary(
            dimension=d3(5.0, 1.2, 0.0),
            position=v3(50.0, 0.0, 0.0),
            base_polygon=[v2(-2.5, -0.6), v2(2.5, -0.6), v2(2.5, 0.6), v2(-2.5, 0.6)],
        ),
        classification=RMC(
            type=RMC.TYPE_SYMBOLIC_TRAFFIC_SIGN,
            traffic_main_sign_type=MSC.TYPE_STOP,
            monochrome_color=RMC.COLOR_WHITE,
            value=tsign.TrafficSignValue(text="STOP"),
            value_text="STOP",
            assigned_lane_id=[ident(3)],
            is_out_of_service=False,
            country="DE",
        ),
    )
    ground_truth = gt.GroundTruth(
        version=version(),
        timestamp=ts(-5, 250_000_000),
        host_vehicle_id=ident(0),
        stationary_object=[pole],
        moving_object=[host, pedestrian, car],
        traffic_sign=[traffic_sign],
        traffic_light=[traffic_light],
        road_marking=[road_marking],
        lane_boundary=[boundary],
        lane=[ego_lane],
        environmental_conditions=conditions,
        country_code=U32_MAX,
        proj_string="+proj=tmerc +lat_0=48.1 +lon_0=11.5 +ellps=WGS84 +units=m 🌍",
        map_reference="München-Ring.xodr",
        model_reference="",
        reference_line=[refline.ReferenceLine(id=ident(5))],  # outside the subset
        proj_frame_offset=gt.GroundTruth.ProjFrameOffset(position=v3(-691000.5, -5335000.25, 0.0), yaw=-0.5),
    )
    RC = svc.RadarSensorViewConfiguration
    CC = svc.CameraSensorViewConfiguration
    return sv.SensorView(
        version=version(),
        timestamp=ts(0, 0),
        sensor_id=ident(0),
        mounting_position=mount,
        mounting_position_rmse=mount_rmse,
        host_vehicle_data=hvd.HostVehicleData(host_vehicle_id=ident(0)),  # outside the subset
        global_ground_truth=ground_truth,
        host_vehicle_id=ident(0),
        generic_sensor_view=[
            sv.GenericSensorView(
                view_configuration=svc.GenericSensorViewConfiguration(
                    sensor_id=ident(0),
                    mounting_position=mount,
                    mounting_position_rmse=mount_rmse,
                    field_of_view_horizontal=6.283185307179586,
                    field_of_view_vertical=0.5,
                )
            )
        ],
        radar_sensor_view=[
            sv.RadarSensorView(
                view_configuration=RC(
                    sensor_id=ident(1),
                    mounting_position=mount,
                    field_of_view_horizontal=1.5707963267948966,
                    field_of_view_vertical=0.17453292519943295,
                    number_of_rays_horizontal=512,
                    number_of_rays_vertical=0,
                    max_number_of_interactions=3,
                    emitter_frequency=77e9,
                    tx_antenna_diagram=[
                        RC.AntennaDiagramEntry(horizontal_angle=-0.5, vertical_angle=0.0, response=-3.0)
                    ],
                    rx_antenna_diagram=[
                        RC.AntennaDiagramEntry(horizontal_angle=0.5, vertical_angle=-0.1, response=-6.5),
                        RC.AntennaDiagramEntry(),
                    ],
                ),
                reflection=[
                    sv.RadarSensorView.Reflection(
                        signal_strength=-90.5,
                        time_of_flight=2e-7,
                        doppler_shift=-1234.5,
                        source_horizontal_angle=-0.1,
                        source_vertical_angle=0.02,
                    ),
                    sv.RadarSensorView.Reflection(signal_strength=0.0),
                ],
            )
        ],
        lidar_sensor_view=[
            sv.LidarSensorView(
                view_configuration=svc.LidarSensorViewConfiguration(
                    sensor_id=ident(2),
                    mounting_position=mount,
                    mounting_position_rmse=mount_rmse,
                    field_of_view_horizontal=6.283185307179586,
                    field_of_view_vertical=0.5235987755982988,
                    number_of_rays_horizontal=1800,
                    number_of_rays_vertical=32,
                    max_number_of_interactions=1,
                    emitter_frequency=3.5e14,
                    num_of_pixels=3,
                    directions=[v3(1, 0, 0), v3(0, 1, 0), v3(-0.5, -0.5, -0.7071)],
                    timings=[0, 7, U32_MAX],
                ),
                reflection=[
                    sv.LidarSensorView.Reflection(
                        signal_strength=-60.0,
                        time_of_flight=1e-7,
                        doppler_shift=0.0,
                        normal_to_surface=v3(-1, 0, 0),
                        object_id=ident(0),
                    ),
                    sv.LidarSensorView.Reflection(object_id=ident(U64_MAX)),
                ],
            )
        ],
        camera_sensor_view=[
            sv.CameraSensorView(
                view_configuration=CC(
                    sensor_id=ident(3),
                    mounting_position=mount,
                    field_of_view_horizontal=1.0471975511965976,
                    field_of_view_vertical=0.6981317007977318,
                    number_of_pixels_horizontal=4,
                    number_of_pixels_vertical=2,
                    channel_format=[
                        CC.CHANNEL_FORMAT_RGB_U8_LIN,
                        CC.CHANNEL_FORMAT_BAYER_RGGB_U16_LIN,
                        CC.CHANNEL_FORMAT_UNKNOWN,
                    ],
                    samples_per_pixel=1,
                    max_number_of_interactions=2,
                    wavelength_data=[common.WavelengthData(start=4e-7, end=7e-7, samples_number=3)],
                    pixel_order=CC.PIXEL_ORDER_LEFT_RIGHT_BOTTOM_TOP,
                ),
                image_data=bytes(range(256)) + b"\x00\xff",
            )
        ],
        ultrasonic_sensor_view=[
            sv.UltrasonicSensorView(
                view_configuration=svc.UltrasonicSensorViewConfiguration(
                    sensor_id=ident(4), field_of_view_horizontal=2.0
                )
            )
        ],
    )


def rich_sensor_view_configuration() -> svc.SensorViewConfiguration:
    view = rich_sensor_view()
    return svc.SensorViewConfiguration(
        version=version(),
        sensor_id=ident(0),
        mounting_position=view.mounting_position,
        mounting_position_rmse=view.mounting_position_rmse,
        field_of_view_horizontal=1.5707963267948966,
        field_of_view_vertical=0.17453292519943295,
        range=200.0,
        update_cycle_time=ts(0, 50_000_000),
        update_cycle_offset=ts(0, 0),
        simulation_start_time=ts(-10, 5),
        omit_static_information=False,
        generic_sensor_view_configuration=[view.generic_sensor_view[0].view_configuration],
        radar_sensor_view_configuration=[view.radar_sensor_view[0].view_configuration],
        lidar_sensor_view_configuration=[view.lidar_sensor_view[0].view_configuration],
        camera_sensor_view_configuration=[view.camera_sensor_view[0].view_configuration],
        ultrasonic_sensor_view_configuration=[view.ultrasonic_sensor_view[0].view_configuration],
    )


def sensor_mounting():
    return mp(v3(3.7, -0.25, 0.5), o3(0.0, -0.01, 0.02))


def sensor_mounting_rmse():
    return mp(v3(0.01, 0.01, 0.02), o3(0.001, 0.002, 0.003))


def detection_header(n):
    H = feat.SensorDetectionHeader
    return H(
        measurement_time=ts(12, 300_000_000),
        cycle_counter=0,
        mounting_position=sensor_mounting(),
        mounting_position_rmse=sensor_mounting_rmse(),
        data_qualifier=H.DATA_QUALIFIER_AVAILABLE,
        number_of_valid_detections=n,
        sensor_id=ident(0),
        extended_qualifier=H.EXTENDED_QUALIFIER_NORMAL_OPERATION_MODE,
    )


def entity_header(cycle_counter, q):
    return sd.DetectedEntityHeader(
        measurement_time=ts(12, 300_000_000), cycle_counter=cycle_counter, data_qualifier=q
    )


def rich_sensor_data() -> sd.SensorData:
    """Mirror of `rich_sensor_data()` in examples/osi_wire.rs."""
    DMO = detobj.DetectedMovingObject
    DIH = detobj.DetectedItemHeader
    VC = obj.MovingObject.VehicleClassification
    LS = VC.LightState
    SC = obj.StationaryObject.Classification
    DQ = sd.DetectedEntityHeader
    moving = [
        DMO(
            header=DIH(
                tracking_id=ident(0),
                ground_truth_id=[ident(0), ident(U64_MAX - 1)],
                existence_probability=0.97,
                age=1.5,
                measurement_state=DIH.MEASUREMENT_STATE_MEASURED,
                sensor_id=[ident(0)],
            ),
            base=common.BaseMoving(
                dimension=d3(4.6, 1.85, 1.45),
                position=v3(26.3, -0.4, 0.1),
                orientation=o3(0.0, 0.0, -0.05),
                velocity=v3(-2.5, 0.0, 0.0),
                acceleration=v3(-0.25, 0.125, 0.0),
                orientation_rate=o3(0.0, 0.0, -0.01),
                orientation_acceleration=o3(0.0, 0.0, 0.001),
                base_polygon=[v2(2.3, 0.9), v2(-2.3, 0.9), v2(-2.3, -0.9), v2(2.3, -0.9)],
            ),
            base_rmse=common.BaseMoving(position=v3(0.2, 0.1, 0.05)),
            reference_point=DMO.REFERENCE_POINT_CENTER,
            movement_state=DMO.MOVEMENT_STATE_MOVING,
            percentage_side_lane_left=0.0,
            percentage_side_lane_right=12.5,
            candidate=[
                DMO.CandidateMovingObject(
                    probability=0.9,
                    type=obj.MovingObject.TYPE_VEHICLE,
                    vehicle_classification=VC(
                        type=VC.TYPE_CAR,
                        light_state=LS(
                            indicator_state=LS.INDICATOR_STATE_LEFT,
                            brake_light_state=LS.BRAKE_LIGHT_STATE_NORMAL,
                            tail_light=LS.GENERIC_LIGHT_STATE_ON,
                        ),
                        has_trailer=False,
                        role=VC.ROLE_CIVIL,
                    ),
                ),
                DMO.CandidateMovingObject(
                    probability=0.1, type=obj.MovingObject.TYPE_PEDESTRIAN, head_pose=o3(0.0, 0.0, 0.3)
                ),
            ],
            color_description=common.ColorDescription(rgb=common.ColorRGB(red=0.8, green=0.1, blue=0.1)),
            radar_specifics=spec.RadarSpecificObjectData(rcs=-7.5),
        ),
        DMO(
            header=DIH(
                tracking_id=ident(7),
                ground_truth_id=[ident(42)],
                existence_probability=0.5,
                measurement_state=DIH.MEASUREMENT_STATE_PREDICTED,
            ),
            base=common.BaseMoving(position=v3(-15.0, 3.5, 0.0)),
            lidar_specifics=spec.LidarSpecificObjectData(),
            camera_specifics=spec.CameraSpecificObjectData(),
        ),
    ]
    stationary = [
        detobj.DetectedStationaryObject(
            header=DIH(tracking_id=ident(3), ground_truth_id=[ident(1001)], existence_probability=1.0),
            base=common.BaseStationary(
                dimension=d3(0.3, 0.3, 2.0),
                position=v3(40.0, -6.0, 1.0),
                orientation=o3(0.0, 0.0, 0.0),
                base_polygon=[v2(0.15, 0.15), v2(-0.15, 0.15), v2(-0.15, -0.15)],
            ),
            candidate=[
                detobj.DetectedStationaryObject.CandidateStationaryObject(
                    probability=1.0,
                    classification=SC(
                        type=SC.TYPE_POLE,
                        material=SC.MATERIAL_METAL,
                        density=SC.DENSITY_SOLID,
                        color=SC.COLOR_GRAY,
                        assigned_lane_id=[ident(0), ident(5)],
                        assigned_lane_percentage=[0.0, -1.5, 100.0],
                    ),
                )
            ],
            radar_specifics=spec.RadarSpecificObjectData(rcs=10.0),
        )
    ]
    radar = feat.RadarDetectionData(
        header=detection_header(2),
        detection=[
            feat.RadarDetection(
                existence_probability=0.99,
                object_id=ident(0),
                position=sph(30.0, -0.05, 0.01),
                position_rmse=sph(0.1, 0.002, 0.004),
                radial_velocity=-2.5,
                radial_velocity_rmse=0.05,
                rcs=-3.25,
                snr=21.5,
                point_target_probability=0.0,
                ambiguity_id=ident(0),
                classification=feat.DETECTION_CLASSIFICATION_CLUTTER,
            ),
            feat.RadarDetection(
                object_id=ident(U64_MAX),
                position=sph(150.0, 0.7, -0.02),
                radial_velocity=13.9,
                rcs=5.0,
                classification=feat.DETECTION_CLASSIFICATION_UNKNOWN,
            ),
        ],
    )
    lidar = feat.LidarDetectionData(
        header=detection_header(2),
        detection=[
            feat.LidarDetection(
                existence_probability=1.0,
                object_id=ident(42),
                position=sph(25.5, 0.1, -0.02),
                position_rmse=sph(0.02, 0.001, 0.001),
                height=0.5,
                height_rmse=0.01,
                intensity=37.5,
                free_space_probability=0.0,
                classification=feat.DETECTION_CLASSIFICATION_UNDERDRIVABLE,
                reflectivity=0.12,
                echo_pulse_width=3.5e-9,
                radial_velocity=-0.75,
                beam_id=ident(63),
            ),
            feat.LidarDetection(position=sph(1e-3, -3.0, 0.5), intensity=0.0, beam_id=ident(0)),
        ],
    )
    CD = feat.CameraDetection
    camera = feat.CameraDetectionData(
        header=detection_header(1),
        specific_header=feat.CameraDetectionSpecificHeader(number_of_valid_points=4),
        detection=[
            CD(
                existence_probability=0.8,
                object_id=ident(0),
                time_difference=ts(0, 1_000_000),
                image_shape_type=CD.IMAGE_SHAPE_TYPE_BOX,
                shape_classification_background=False,
                shape_classification_moving_object=True,
                shape_classification_vehicle=True,
                shape_classification_pedestrian_rear=False,
                shape_classification_probability=0.75,
                color=CD.COLOR_RED,
                color_probability=0.6,
                ambiguity_id=ident(2),
                first_point_index=0,
                number_of_points=4,
                color_description=common.ColorDescription(grey=common.ColorGrey(grey=0.5)),
            )
        ],
        point=[
            feat.CameraPoint(
                existence_probability=1.0, point=sph(30.0, az, el), point_rmse=sph(0.0, 0.001, 0.001)
            )
            for az, el in [(-0.1, 0.02), (0.1, 0.02), (0.1, -0.02), (-0.1, -0.02)]
        ],
    )
    ultrasonic = feat.UltrasonicDetectionData(
        header=detection_header(1),
        specific_header=feat.UltrasonicDetectionSpecificHeader(
            max_range=5.0, number_of_valid_indirect_detections=1
        ),
        detection=[feat.UltrasonicDetection(existence_probability=1.0, object_id=ident(0), distance=2.5)],
        indirect_detection=[
            feat.UltrasonicIndirectDetection(
                existence_probability=0.5,
                object_id=ident(0),
                ellipsoid_radial=1.0,
                ellipsoid_axial=0.5,
                receiver_id=ident(1),
                receiver_origin=v3(-0.1, 0.2, 0.3),
            )
        ],
    )
    LH = logical.LogicalDetectionDataHeader
    return sd.SensorData(
        version=version(),
        timestamp=ts(12, 345_000_000),
        host_vehicle_location=common.BaseMoving(
            dimension=d3(4.5, 1.8, 1.4),
            position=v3(-1234.5, 987.25, -0.5),
            orientation=o3(0.0, 0.0, -1.5),
            velocity=v3(-13.9, 0.1, 0.0),
            acceleration=v3(-0.5, 0.0, 0.0),
            orientation_rate=o3(0.0, 0.0, -0.01),
            orientation_acceleration=o3(0.0, 0.0, 0.001),
            base_polygon=[v2(2.25, 0.9), v2(-2.25, 0.9), v2(-2.25, -0.9)],
            bounding_box_section=[
                common.BoundingBox(
                    dimension=d3(0.2, 0.25, 0.15),
                    position=v3(0.9, 1.0, 0.3),
                    orientation=o3(0.0, 0.0, 0.0),
                    contained_object_type=common.BoundingBox.TYPE_SIDE_MIRROR,
                    model_reference="mirror_L.glb",
                )
            ],
        ),
        host_vehicle_location_rmse=common.BaseMoving(position=v3(0.1, 0.1, 0.2)),
        sensor_id=ident(0),
        mounting_position=sensor_mounting(),
        mounting_position_rmse=sensor_mounting_rmse(),
        sensor_view=[
            sv.SensorView(
                version=version(), timestamp=ts(12, 345_000_000), sensor_id=ident(0), host_vehicle_id=ident(0)
            )
        ],
        last_measurement_time=ts(12, 300_000_000),
        stationary_object_header=entity_header(U64_MAX, DQ.DATA_QUALIFIER_BLINDNESS),
        stationary_object=stationary,
        moving_object_header=entity_header(0, DQ.DATA_QUALIFIER_AVAILABLE),
        moving_object=moving,
        traffic_sign_header=entity_header(1, DQ.DATA_QUALIFIER_NOT_AVAILABLE),
        traffic_sign=[
            dts.DetectedTrafficSign(
                header=DIH(tracking_id=ident(77), ground_truth_id=[ident(77)], existence_probability=0.8, age=0.0),
                main_sign=dts.DetectedTrafficSign.DetectedMainSign(
                    candidate=[
                        dts.DetectedTrafficSign.DetectedMainSign.CandidateMainSign(
                            probability=1.0,
                            classification=tsign.TrafficSign.MainSign.Classification(
                                type=tsign.TrafficSign.MainSign.Classification.TYPE_SPEED_LIMIT_BEGIN,
                                value=tsign.TrafficSignValue(
                                    value=50.0, value_unit=tsign.TrafficSignValue.UNIT_KILOMETER_PER_HOUR
                                ),
                            ),
                        )
                    ],
                    base=common.BaseStationary(dimension=d3(0.02, 0.6, 0.6), position=v3(39.5, -4.4, 0.8)),
                    geometry=dts.DetectedTrafficSign.DetectedMainSign.GEOMETRY_CIRCLE,
                ),
                supplementary_sign=[
                    dts.DetectedTrafficSign.DetectedSupplementarySign(
                        candidate=[
                            dts.DetectedTrafficSign.DetectedSupplementarySign.CandidateSupplementarySign(
                                probability=0.5,
                                classification=tsign.TrafficSign.SupplementarySign.Classification(
                                    type=tsign.TrafficSign.SupplementarySign.Classification.TYPE_TIME
                                ),
                            )
                        ],
                    )
                ],
            )
        ],
        traffic_light_header=entity_header(3, DQ.DATA_QUALIFIER_AVAILABLE),
        traffic_light=[
            dtl.DetectedTrafficLight(
                header=DIH(tracking_id=ident(78), ground_truth_id=[ident(78)]),
                base=common.BaseStationary(dimension=d3(0.05, 0.2, 0.2), position=v3(59.0, 3.1, 4.0)),
                candidate=[
                    dtl.DetectedTrafficLight.CandidateTrafficLight(
                        probability=1.0,
                        classification=tlight.TrafficLight.Classification(
                            color=tlight.TrafficLight.Classification.COLOR_RED,
                            mode=tlight.TrafficLight.Classification.MODE_OFF,
                            counter=0.0,
                        ),
                    )
                ],
            )
        ],
        road_marking_header=entity_header(4, DQ.DATA_QUALIFIER_AVAILABLE_REDUCED),
        road_marking=[
            drm.DetectedRoadMarking(
                header=DIH(tracking_id=ident(79), ground_truth_id=[ident(79)]),
                base=common.BaseStationary(position=v3(49.0, 0.1, -1.5)),
                candidate=[
                    drm.DetectedRoadMarking.CandidateRoadMarking(
                        probability=0.9,
                        classification=rmark.RoadMarking.Classification(
                            type=rmark.RoadMarking.Classification.TYPE_GENERIC_LINE,
                            monochrome_color=rmark.RoadMarking.Classification.COLOR_WHITE,
                        ),
                    )
                ],
            )
        ],
        lane_boundary_header=entity_header(2, DQ.DATA_QUALIFIER_UNKNOWN),
        lane_boundary=[
            dlane.DetectedLaneBoundary(
                header=DIH(tracking_id=ident(300), ground_truth_id=[ident(300)], existence_probability=0.75),
                candidate=[
                    dlane.DetectedLaneBoundary.CandidateLaneBoundary(
                        probability=1.0,
                        classification=lane.LaneBoundary.Classification(
                            type=lane.LaneBoundary.Classification.TYPE_DASHED_LINE,
                            color=lane.LaneBoundary.Classification.COLOR_WHITE,
                        ),
                    )
                ],
                boundary_line=[
                    lane.LaneBoundary.BoundaryPoint(position=v3(6.0, 1.75, -1.5), width=0.12),
                    lane.LaneBoundary.BoundaryPoint(
                        position=v3(8.0, 1.74, -1.5), dash=lane.LaneBoundary.BoundaryPoint.DASH_END
                    ),
                ],
                boundary_line_confidences=[0.9, 0.0],
            )
        ],
        feature_data=feat.FeatureData(
            version=version(),
            radar_sensor=[radar],
            lidar_sensor=[lidar],
            ultrasonic_sensor=[ultrasonic],
            camera_sensor=[camera],
        ),
        logical_detection_data=logical.LogicalDetectionData(
            version=version(),
            header=LH(
                logical_detection_time=ts(12, 300_000_000),
                data_qualifier=LH.DATA_QUALIFIER_AVAILABLE,
                number_of_valid_logical_detections=1,
                sensor_id=[ident(0)],
            ),
            logical_detection=[
                logical.LogicalDetection(
                    existence_probability=0.9,
                    object_id=ident(42),
                    position=v3(26.0, -0.4, 0.5),
                    position_rmse=v3(0.1, 0.1, 0.1),
                    velocity=v3(-2.5, 0.0, 0.0),
                    velocity_rmse=v3(0.05, 0.05, 0.05),
                    intensity=40.0,
                    snr=12.0,
                    point_target_probability=0.1,
                    sensor_id=[ident(0), ident(1)],
                    classification=logical.LOGICAL_DETECTION_CLASSIFICATION_OVERDRIVABLE,
                    echo_pulse_width=4e-9,
                )
            ],
        ),
        virtual_detection_area=sd.SensorData.VirtualDetectionArea(
            polygon=[
                common.Polygon3d(vertex=[v3(0.0, 0.0, 0.0), v3(200.0, -100.0, 0.0), v3(200.0, 100.0, 0.0)])
            ]
        ),
        system_time=ts(-3, 999_999_999),
    )


def golden_messages() -> dict:
    """Mirror of `golden_messages()` in examples/osi_wire.rs."""
    CC = svc.CameraSensorViewConfiguration
    LS = obj.MovingObject.VehicleClassification.LightState
    E = env.EnvironmentalConditions
    SC = obj.StationaryObject.Classification
    RC = svc.RadarSensorViewConfiguration
    return {
        "identifier_zero": ident(0),
        "identifier_max": ident(U64_MAX),
        "timestamp_zero": ts(0, 0),
        "timestamp_negative": ts(-1, 500_000_000),
        "interface_version": version(),
        "mounting_position": mp(v3(-1.25, 0.0, 1e-300), o3(-0.0, math.pi, -2.5)),
        "base_moving_out_of_order": common.BaseMoving(
            dimension=d3(4.0, 2.0, 1.5),
            orientation_acceleration=o3(0.0, 0.0, -0.5),
            base_polygon=[v2(1.0, -1.0), v2(-1.0, -1.0)],
            bounding_box_section=[common.BoundingBox(contained_object_type=common.BoundingBox.TYPE_CARGO)],
        ),
        "light_state": LS(
            indicator_state=LS.INDICATOR_STATE_WARNING,
            head_light=LS.GENERIC_LIGHT_STATE_ON,
            tail_light=LS.GENERIC_LIGHT_STATE_OFF,
            brake_light_state=LS.BRAKE_LIGHT_STATE_STRONG,
            service_vehicle_illumination=LS.GENERIC_LIGHT_STATE_UNKNOWN,
        ),
        "environmental_conditions": E(
            ambient_illumination=E.AMBIENT_ILLUMINATION_LEVEL9,
            time_of_day=E.TimeOfDay(seconds_since_midnight=0),
            unix_timestamp=-86_400,
            temperature=253.15,
            precipitation=E.PRECIPITATION_EXTREME,
            fog=E.FOG_DENSE,
        ),
        "lidar_view_configuration": svc.LidarSensorViewConfiguration(
            sensor_id=ident(0),
            field_of_view_horizontal=math.tau,
            number_of_rays_horizontal=0,
            num_of_pixels=3,
            directions=[v3(1.0, 0.0, 0.0), v3(0.0, -1.0, 0.0)],
            timings=[0, 1, U32_MAX],
        ),
        "camera_view_configuration": CC(
            number_of_pixels_horizontal=1920,
            number_of_pixels_vertical=1080,
            channel_format=[
                CC.CHANNEL_FORMAT_RGB_U8_LIN,
                CC.CHANNEL_FORMAT_MONO_F32_LIN,
                CC.CHANNEL_FORMAT_OTHER,
            ],
            samples_per_pixel=1,
            wavelength_data=[common.WavelengthData(start=380e-9, end=780e-9, samples_number=41.0)],
            pixel_order=CC.PIXEL_ORDER_DEFAULT,
        ),
        "lidar_reflection": sv.LidarSensorView.Reflection(
            signal_strength=-80.5,
            time_of_flight=2e-7,
            doppler_shift=-1500.0,
            normal_to_surface=v3(-1.0, 0.0, 0.0),
            object_id=ident(0),
        ),
        "stationary_classification": SC(
            type=SC.TYPE_EMITTING_STRUCTURE,
            assigned_lane_id=[ident(3), ident(0)],
            assigned_lane_percentage=[50.0, -0.0, 1e300],
        ),
        "sensor_view_configuration": svc.SensorViewConfiguration(
            version=version(),
            sensor_id=ident(0),
            mounting_position=sensor_mounting(),
            field_of_view_horizontal=math.pi / 2,
            field_of_view_vertical=0.17453292519943295,
            range=200.0,
            update_cycle_time=ts(0, 50_000_000),
            update_cycle_offset=ts(0, 0),
            simulation_start_time=ts(-10, 0),
            omit_static_information=False,
            radar_sensor_view_configuration=[
                RC(
                    sensor_id=ident(0),
                    mounting_position=sensor_mounting(),
                    field_of_view_horizontal=math.pi / 2,
                    field_of_view_vertical=0.17453292519943295,
                    number_of_rays_horizontal=512,
                    number_of_rays_vertical=16,
                    max_number_of_interactions=3,
                    emitter_frequency=77e9,
                    tx_antenna_diagram=[
                        RC.AntennaDiagramEntry(horizontal_angle=-0.5, vertical_angle=0.0, response=-3.0)
                    ],
                )
            ],
        ),
        "sensor_data_minimal": sd.SensorData(
            version=version(), timestamp=ts(0, 0), sensor_id=ident(0), mounting_position=sensor_mounting()
        ),
        "sensor_data_empty": sd.SensorData(),
    }


# ---------------------------------------------------------------------------------------------
# (b) osi3 -> prost


def test_rich_sensor_view_is_rich():
    paths = set(message_paths(rich_sensor_view()))
    for must in (
        "sensor_id.value",
        "host_vehicle_id.value",
        "global_ground_truth.moving_object.vehicle_attributes.bbcenter_to_rear.x",
        "global_ground_truth.moving_object.vehicle_classification.light_state.tail_light",
        "global_ground_truth.moving_object.model_reference",
        "global_ground_truth.moving_object.pedestrian_attributes.skeleton_bone.length",
        "global_ground_truth.stationary_object.classification.assigned_lane_percentage",
        "global_ground_truth.lane_boundary.boundary_line.dash",
        "global_ground_truth.lane.classification.road_condition.surface_ice",
        "global_ground_truth.environmental_conditions.unix_timestamp",
        "radar_sensor_view.view_configuration.rx_antenna_diagram.response",
        "lidar_sensor_view.view_configuration.timings",
        "camera_sensor_view.view_configuration.channel_format",
        "camera_sensor_view.image_data",
        "ultrasonic_sensor_view.view_configuration.sensor_id",
    ):
        assert must in paths, must


@pytest.mark.parametrize(
    "type_name, build, expect_dropped",
    [
        (
            "osi3.SensorView",
            rich_sensor_view,
            {
                "osi3.SensorView.host_vehicle_data",
                "osi3.GroundTruth.reference_line",
            },
        ),
        (
            "osi3.GroundTruth",
            lambda: rich_sensor_view().global_ground_truth,
            {"osi3.GroundTruth.reference_line"},
        ),
        ("osi3.SensorViewConfiguration", rich_sensor_view_configuration, set()),
        ("osi3.SensorData", rich_sensor_data, set()),
    ],
)
def test_osi3_message_decodes_in_prost(osi_wire, our_pool, tmp_path, type_name, build, expect_dropped):
    msg = build()
    path = tmp_path / "in.pb"
    path.write_bytes(msg.SerializeToString())

    dropped: set[str] = set()
    expected_msg = project(msg, our_pool, dropped)
    assert dropped == expect_dropped

    # Value by value (the JSON mirrors MessageToDict; see examples/osi_wire.rs).
    actual = osi_wire.decode_json(type_name, path)
    expected = to_dict(expected_msg)
    differences = json_diff(actual, expected)
    assert not differences, f"{len(differences)} differences:\n" + "\n".join(differences[:50])

    # Byte by byte: the prost re-encoding equals osi3's encoding minus the fields outside the subset.
    out = tmp_path / "out.pb"
    osi_wire.run("reencode", type_name, path, out)
    assert out.read_bytes() == expected_msg.SerializeToString()


def test_decode_sensor_view_subcommand(osi_wire, our_pool, tmp_path):
    """The `decode-sensor-view FILE` spelling, and presence-sensitive values spelled out."""
    msg = rich_sensor_view()
    path = tmp_path / "sv.pb"
    path.write_bytes(msg.SerializeToString())
    j = json.loads(osi_wire.run("decode-sensor-view", path, stdout_expected=True))
    assert j["sensor_id"] == {"value": "0"}  # id 0 keeps presence (proto2)
    assert j["host_vehicle_id"] == {"value": "0"}
    assert j["timestamp"] == {"seconds": "0", "nanos": 0}
    assert "host_vehicle_data" not in j
    g = j["global_ground_truth"]
    assert g["timestamp"] == {"seconds": "-5", "nanos": 250000000}
    assert g["country_code"] == U32_MAX
    assert g["model_reference"] == ""
    assert g["environmental_conditions"]["unix_timestamp"] == "-1700000000"
    assert g["environmental_conditions"]["sun"]["intensity"] == "Infinity"
    host = g["moving_object"][0]
    assert host["id"] == {"value": "0"}
    assert host["model_reference"] == UNICODE
    assert host["vehicle_attributes"]["wheel_data"][0]["rotation_rate"] == "NaN"
    assert host["vehicle_attributes"]["bbcenter_to_rear"] == {"x": -1.4, "y": 0.0, "z": -0.4}
    assert host["vehicle_classification"]["light_state"]["tail_light"] == 3
    assert g["moving_object"][1]["id"] == {"value": str(U64_MAX - 1)}
    assert g["moving_object"][1]["pedestrian_attributes"]["skeleton_bone"][0]["length"] == 0.1
    pole = g["stationary_object"][0]["classification"]
    assert pole["material"] == 7 and pole["color"] == 9  # aliases arrive as their number
    assert pole["assigned_lane_percentage"] == [0.0, 33.3, -0.0]
    lidar = j["lidar_sensor_view"][0]
    assert lidar["view_configuration"]["timings"] == [0, 7, U32_MAX]
    assert lidar["reflection"][1]["object_id"] == {"value": str(U64_MAX)}
    cam = j["camera_sensor_view"][0]
    assert base64.b64decode(cam["image_data"]) == bytes(range(256)) + b"\x00\xff"
    assert cam["view_configuration"]["channel_format"] == [6, 15, 0]


def test_osi_wire_reports_errors_on_stderr(osi_wire, tmp_path):
    garbage = tmp_path / "garbage.pb"
    garbage.write_bytes(b"\xff\xff\xff\xff\xff")
    proc = osi_wire.run_fail("decode", "osi3.SensorView", garbage)
    assert proc.returncode != 0 and proc.stdout == b"" and b"error" in proc.stderr
    proc = osi_wire.run_fail("decode", "osi3.NoSuchMessage", garbage)
    assert proc.returncode != 0 and proc.stdout == b"" and b"NoSuchMessage" in proc.stderr
    proc = osi_wire.run_fail("no-such-subcommand")
    assert proc.returncode == 2 and proc.stdout == b"" and b"usage" in proc.stderr


# ---------------------------------------------------------------------------------------------
# (c) prost -> osi3


def test_rust_sensor_data_decodes_in_osi3(osi_wire, tmp_path):
    path = tmp_path / "sd.pb"
    osi_wire.run("encode-sensor-data", path)
    data = path.read_bytes()
    got = sd.SensorData.FromString(data)
    assert_no_unknown_fields(got)
    expected = rich_sensor_data()

    differences = json_diff(to_dict(got), to_dict(expected))
    assert not differences, "\n".join(differences[:50])
    assert got == expected
    assert data == expected.SerializeToString()

    # Spelled-out spot checks of the parts osiris sensors rely on.
    assert (got.version.version_major, got.version.version_minor, got.version.version_patch) == (3, 8, 0)
    assert got.HasField("sensor_id") and got.sensor_id.HasField("value") and got.sensor_id.value == 0
    assert got.system_time.seconds == -3 and got.system_time.nanos == 999_999_999
    assert got.moving_object_header.HasField("cycle_counter") and got.moving_object_header.cycle_counter == 0
    assert got.stationary_object_header.cycle_counter == U64_MAX
    front = got.moving_object[0]
    assert [i.value for i in front.header.ground_truth_id] == [0, U64_MAX - 1]
    assert front.header.tracking_id.HasField("value")
    assert front.base.velocity.x == -2.5 and front.radar_specifics.rcs == -7.5
    assert front.candidate[0].vehicle_classification.light_state.tail_light == 3
    assert got.moving_object[1].HasField("lidar_specifics") and got.moving_object[1].HasField(
        "camera_specifics"
    )
    mount = got.mounting_position
    assert (mount.position.x, mount.position.y, mount.position.z) == (3.7, -0.25, 0.5)
    fd = got.feature_data
    for header in (fd.radar_sensor[0].header, fd.lidar_sensor[0].header, fd.camera_sensor[0].header):
        assert header.mounting_position == got.mounting_position
        assert header.HasField("cycle_counter") and header.cycle_counter == 0
    r = fd.radar_sensor[0].detection
    assert (r[0].position.distance, r[0].position.azimuth, r[0].radial_velocity) == (30.0, -0.05, -2.5)
    assert r[1].object_id.value == U64_MAX
    li = fd.lidar_sensor[0].detection
    assert li[0].intensity == 37.5 and li[0].beam_id.value == 63 and li[1].beam_id.HasField("value")
    cam = fd.camera_sensor[0]
    assert cam.detection[0].shape_classification_vehicle is True
    assert cam.detection[0].HasField("shape_classification_background")
    assert len(cam.point) == cam.specific_header.number_of_valid_points == 4
    assert got.stationary_object[0].candidate[0].classification.assigned_lane_percentage == [0.0, -1.5, 100.0]


# ---------------------------------------------------------------------------------------------
# (d) golden vectors


@pytest.fixture(scope="session")
def rust_golden(osi_wire, tmp_path_factory) -> dict[str, bytes]:
    d = tmp_path_factory.mktemp("golden")
    osi_wire.run("golden", d)
    return {p.stem: p.read_bytes() for p in sorted(d.glob("*.pb"))}


def test_golden_sets_match(rust_golden):
    assert set(rust_golden) == set(golden_messages())


@pytest.mark.parametrize("name", sorted(golden_messages()))
def test_golden_bytes_identical(rust_golden, name):
    expected = golden_messages()[name].SerializeToString()
    assert rust_golden[name] == expected, f"{name}: rust {rust_golden[name].hex()} != osi3 {expected.hex()}"


def test_golden_known_encodings(rust_golden):
    # Presence of zero values on the wire (proto2).
    assert rust_golden["identifier_zero"] == b"\x08\x00"
    assert rust_golden["timestamp_zero"] == b"\x08\x00\x10\x00"
    assert rust_golden["sensor_data_empty"] == b""
    # Negative int64 as 10-byte two's-complement varint.
    assert rust_golden["timestamp_negative"].startswith(b"\x08" + b"\xff" * 9 + b"\x01")
    # Unpacked repeated uint32 (field 12, wire type 0): one tag per element.
    # Field 12 is the highest field number, so it comes last: tag 0x60 before every element.
    assert rust_golden["lidar_view_configuration"].endswith(bytes.fromhex("6000600160ffffffff0f"))
