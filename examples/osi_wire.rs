//! `osi_wire`: the Rust side of the wire-compatibility tests against the official ASAM OSI
//! implementation (`tests/python/test_wire_compat.py`, PyPI `osi-python` 3.8.0).
//!
//! ```text
//! osi_wire descriptor-set OUT.pb       write osiris_proto::FILE_DESCRIPTOR_SET
//! osi_wire decode TYPE FILE            decode FILE as TYPE with the prost types, print it as JSON
//! osi_wire decode-sensor-view FILE     = decode osi3.SensorView FILE
//! osi_wire reencode TYPE IN OUT        decode IN with the prost types, encode again into OUT
//! osi_wire encode-sensor-data OUT      write the rich SensorData built by `rich_sensor_data()`
//! osi_wire golden OUT_DIR              write the golden messages as OUT_DIR/<name>.pb
//! ```
//!
//! TYPE is a full name (`osi3.SensorView`, `osi3.SensorData`, `osi3.SensorViewConfiguration`,
//! `osi3.GroundTruth`, `osiris.perception.PerceptionData`); the `osi3.` prefix may be left out.
//!
//! JSON follows protobuf's `MessageToDict(m, preserving_proto_field_name=True,
//! use_integers_for_enums=True)`: proto field names, present fields only (proto2 presence, so an
//! explicit 0 is printed), 64-bit integers as decimal strings, enums as numbers, bytes as padded
//! base64, NaN/±infinity as "NaN"/"Infinity"/"-Infinity", floats (32-bit) as their shortest f32
//! representation. The message is decoded with the generated prost types and encoded again, and
//! the re-encoded bytes are dumped generically with `prost-reflect` against our descriptor set, so
//! what is printed is exactly what the prost types kept (fields outside the subset are dropped).
//!
//! Output goes to stdout only for `decode`; errors go to stderr with exit status 1 (2 for usage).

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, anyhow, bail};
use osiris_proto::osi3::*;
use osiris_proto::{Message, perception};
use prost_reflect::{DescriptorPool, DynamicMessage, Kind, Value};
use serde_json::{Map, Value as Json};

const USAGE: &str = "usage: osi_wire descriptor-set OUT.pb
       osi_wire decode TYPE FILE
       osi_wire decode-sensor-view FILE
       osi_wire reencode TYPE IN OUT
       osi_wire encode-sensor-data OUT
       osi_wire golden OUT_DIR";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let result = match args.as_slice() {
        ["descriptor-set", out] => write(out, osiris_proto::FILE_DESCRIPTOR_SET),
        ["decode", ty, file] => decode(ty, file),
        ["decode-sensor-view", file] => decode("osi3.SensorView", file),
        ["reencode", ty, input, out] => reencode(ty, input, out),
        ["encode-sensor-data", out] => write(out, &rich_sensor_data().encode_to_vec()),
        ["golden", dir] => write_golden(dir),
        _ => {
            eprintln!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("osi_wire: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn write(path: &str, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("writing {path}"))
}

fn read(path: &str) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("reading {path}"))
}

fn full_name(ty: &str) -> String {
    if ty.contains('.') {
        ty.to_string()
    } else {
        format!("osi3.{ty}")
    }
}

/// Decode with the generated prost type of `ty` and encode again.
fn prost_roundtrip(ty: &str, bytes: &[u8]) -> Result<Vec<u8>> {
    fn rt<M: Message + Default>(bytes: &[u8]) -> Result<Vec<u8>> {
        Ok(M::decode(bytes)?.encode_to_vec())
    }
    match full_name(ty).as_str() {
        "osi3.SensorView" => rt::<SensorView>(bytes),
        "osi3.SensorData" => rt::<SensorData>(bytes),
        "osi3.SensorViewConfiguration" => rt::<SensorViewConfiguration>(bytes),
        "osi3.GroundTruth" => rt::<GroundTruth>(bytes),
        "osiris.perception.PerceptionData" => rt::<perception::PerceptionData>(bytes),
        other => bail!("unsupported message type `{other}`"),
    }
    .with_context(|| format!("decoding {ty}"))
}

fn reencode(ty: &str, input: &str, out: &str) -> Result<()> {
    let bytes = prost_roundtrip(ty, &read(input)?)?;
    write(out, &bytes)
}

fn decode(ty: &str, file: &str) -> Result<()> {
    let bytes = prost_roundtrip(ty, &read(file)?)?;
    let pool = DescriptorPool::decode(osiris_proto::FILE_DESCRIPTOR_SET)
        .context("decoding osiris_proto::FILE_DESCRIPTOR_SET")?;
    let name = full_name(ty);
    let desc = pool
        .get_message_by_name(&name)
        .ok_or_else(|| anyhow!("`{name}` is not in the descriptor set"))?;
    let msg = DynamicMessage::decode(desc, bytes.as_slice()).context("reflective decode")?;
    let json = message_to_json(&msg, &name)?;
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{}", serde_json::to_string(&json)?).context("writing to stdout")?;
    stdout.flush().context("writing to stdout")
}

/// Generic message -> JSON (see the module docs for the conventions).
fn message_to_json(msg: &DynamicMessage, path: &str) -> Result<Json> {
    if let Some(u) = msg.unknown_fields().next() {
        bail!(
            "{path}: unknown field {} after the prost round trip",
            u.number()
        );
    }
    let mut obj = Map::new();
    for (field, value) in msg.fields() {
        let path = format!("{path}.{}", field.name());
        let json = match value {
            Value::List(items) => Json::Array(
                items
                    .iter()
                    .map(|v| value_to_json(v, &field.kind(), &path))
                    .collect::<Result<_>>()?,
            ),
            Value::Map(_) => bail!("{path}: map fields are not used by OSI"),
            v => value_to_json(v, &field.kind(), &path)?,
        };
        obj.insert(field.name().to_string(), json);
    }
    Ok(Json::Object(obj))
}

fn value_to_json(value: &Value, kind: &Kind, path: &str) -> Result<Json> {
    Ok(match value {
        Value::Bool(b) => Json::Bool(*b),
        Value::I32(v) => Json::from(*v),
        Value::U32(v) => Json::from(*v),
        Value::I64(v) => Json::String(v.to_string()),
        Value::U64(v) => Json::String(v.to_string()),
        // Shortest representation that round-trips as f32 (what protobuf's JSON printer does).
        Value::F32(v) => float_to_json(f64::from(*v), Some(v.to_string())),
        Value::F64(v) => float_to_json(*v, None),
        Value::String(s) => Json::String(s.clone()),
        Value::Bytes(b) => Json::String(base64(b)),
        Value::EnumNumber(n) => {
            if !matches!(kind, Kind::Enum(_)) {
                bail!("{path}: enum value for a non-enum field");
            }
            Json::from(*n)
        }
        Value::Message(m) => message_to_json(m, path)?,
        Value::List(_) | Value::Map(_) => bail!("{path}: nested list/map"),
    })
}

fn float_to_json(v: f64, shortest: Option<String>) -> Json {
    if v.is_nan() {
        Json::String("NaN".into())
    } else if v.is_infinite() {
        Json::String(if v > 0.0 { "Infinity" } else { "-Infinity" }.into())
    } else {
        let v = shortest.and_then(|s| s.parse::<f64>().ok()).unwrap_or(v);
        serde_json::Number::from_f64(v).map_or(Json::Null, Json::Number)
    }
}

/// Standard base64 with padding (RFC 4648), as protobuf's JSON mapping prints `bytes`.
fn base64(data: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Message builders. tests/python/test_wire_compat.py builds the same messages with osi3 and
// compares values and bytes: change both together.

fn v3(x: f64, y: f64, z: f64) -> Vector3d {
    Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    }
}

fn v2(x: f64, y: f64) -> Vector2d {
    Vector2d {
        x: Some(x),
        y: Some(y),
    }
}

fn o3(roll: f64, pitch: f64, yaw: f64) -> Orientation3d {
    Orientation3d {
        roll: Some(roll),
        pitch: Some(pitch),
        yaw: Some(yaw),
    }
}

fn d3(length: f64, width: f64, height: f64) -> Dimension3d {
    Dimension3d {
        length: Some(length),
        width: Some(width),
        height: Some(height),
    }
}

fn sph(distance: f64, azimuth: f64, elevation: f64) -> Spherical3d {
    Spherical3d {
        distance: Some(distance),
        azimuth: Some(azimuth),
        elevation: Some(elevation),
    }
}

fn ts(seconds: i64, nanos: u32) -> Timestamp {
    Timestamp {
        seconds: Some(seconds),
        nanos: Some(nanos),
    }
}

fn id(value: u64) -> Identifier {
    Identifier { value: Some(value) }
}

fn mp(position: Vector3d, orientation: Orientation3d) -> MountingPosition {
    MountingPosition {
        position: Some(position),
        orientation: Some(orientation),
    }
}

fn version() -> InterfaceVersion {
    osiris_proto::interface_version()
}

fn sensor_mounting() -> MountingPosition {
    mp(v3(3.7, -0.25, 0.5), o3(0.0, -0.01, 0.02))
}

fn sensor_mounting_rmse() -> MountingPosition {
    mp(v3(0.01, 0.01, 0.02), o3(0.001, 0.002, 0.003))
}

fn detection_header(n: u32) -> SensorDetectionHeader {
    use sensor_detection_header::{DataQualifier, ExtendedQualifier};
    SensorDetectionHeader {
        measurement_time: Some(ts(12, 300_000_000)),
        cycle_counter: Some(0),
        mounting_position: Some(sensor_mounting()),
        mounting_position_rmse: Some(sensor_mounting_rmse()),
        data_qualifier: Some(DataQualifier::Available as i32),
        number_of_valid_detections: Some(n),
        sensor_id: Some(id(0)),
        extended_qualifier: Some(ExtendedQualifier::NormalOperationMode as i32),
    }
}

fn entity_header(
    cycle_counter: u64,
    q: detected_entity_header::DataQualifier,
) -> DetectedEntityHeader {
    DetectedEntityHeader {
        measurement_time: Some(ts(12, 300_000_000)),
        cycle_counter: Some(cycle_counter),
        data_qualifier: Some(q as i32),
    }
}

/// A SensorData with every part the osiris sensors write, plus edge values: identifiers 0 and
/// 2^64-1, zero counters (presence), negative numbers, empty sub-messages, unpacked repeated
/// scalars, fields declared out of number order.
fn rich_sensor_data() -> SensorData {
    use detected_entity_header::DataQualifier as Dq;
    use moving_object::vehicle_classification::{self as vc, light_state};

    let moving = vec![
        DetectedMovingObject {
            header: Some(DetectedItemHeader {
                tracking_id: Some(id(0)),
                ground_truth_id: vec![id(0), id(u64::MAX - 1)],
                existence_probability: Some(0.97),
                age: Some(1.5),
                measurement_state: Some(detected_item_header::MeasurementState::Measured as i32),
                sensor_id: vec![id(0)],
            }),
            base: Some(BaseMoving {
                dimension: Some(d3(4.6, 1.85, 1.45)),
                position: Some(v3(26.3, -0.4, 0.1)),
                orientation: Some(o3(0.0, 0.0, -0.05)),
                velocity: Some(v3(-2.5, 0.0, 0.0)),
                acceleration: Some(v3(-0.25, 0.125, 0.0)),
                orientation_rate: Some(o3(0.0, 0.0, -0.01)),
                orientation_acceleration: Some(o3(0.0, 0.0, 0.001)),
                base_polygon: vec![v2(2.3, 0.9), v2(-2.3, 0.9), v2(-2.3, -0.9), v2(2.3, -0.9)],
                bounding_box_section: vec![],
            }),
            base_rmse: Some(BaseMoving {
                position: Some(v3(0.2, 0.1, 0.05)),
                ..Default::default()
            }),
            reference_point: Some(detected_moving_object::ReferencePoint::Center as i32),
            movement_state: Some(detected_moving_object::MovementState::Moving as i32),
            percentage_side_lane_left: Some(0.0),
            percentage_side_lane_right: Some(12.5),
            candidate: vec![
                detected_moving_object::CandidateMovingObject {
                    probability: Some(0.9),
                    r#type: Some(moving_object::Type::Vehicle as i32),
                    vehicle_classification: Some(moving_object::VehicleClassification {
                        r#type: Some(vc::Type::Car as i32),
                        light_state: Some(vc::LightState {
                            indicator_state: Some(light_state::IndicatorState::Left as i32),
                            brake_light_state: Some(light_state::BrakeLightState::Normal as i32),
                            tail_light: Some(light_state::GenericLightState::On as i32),
                            ..Default::default()
                        }),
                        has_trailer: Some(false),
                        trailer_id: None,
                        role: Some(vc::Role::Civil as i32),
                    }),
                    ..Default::default()
                },
                detected_moving_object::CandidateMovingObject {
                    probability: Some(0.1),
                    r#type: Some(moving_object::Type::Pedestrian as i32),
                    head_pose: Some(o3(0.0, 0.0, 0.3)),
                    ..Default::default()
                },
            ],
            color_description: Some(ColorDescription {
                rgb: Some(ColorRgb {
                    red: Some(0.8),
                    green: Some(0.1),
                    blue: Some(0.1),
                }),
                ..Default::default()
            }),
            radar_specifics: Some(RadarSpecificObjectData { rcs: Some(-7.5) }),
            ..Default::default()
        },
        DetectedMovingObject {
            header: Some(DetectedItemHeader {
                tracking_id: Some(id(7)),
                ground_truth_id: vec![id(42)],
                existence_probability: Some(0.5),
                measurement_state: Some(detected_item_header::MeasurementState::Predicted as i32),
                ..Default::default()
            }),
            base: Some(BaseMoving {
                position: Some(v3(-15.0, 3.5, 0.0)),
                ..Default::default()
            }),
            lidar_specifics: Some(LidarSpecificObjectData {}),
            camera_specifics: Some(CameraSpecificObjectData {}),
            ..Default::default()
        },
    ];

    let stationary = vec![DetectedStationaryObject {
        header: Some(DetectedItemHeader {
            tracking_id: Some(id(3)),
            ground_truth_id: vec![id(1001)],
            existence_probability: Some(1.0),
            ..Default::default()
        }),
        base: Some(BaseStationary {
            dimension: Some(d3(0.3, 0.3, 2.0)),
            position: Some(v3(40.0, -6.0, 1.0)),
            orientation: Some(o3(0.0, 0.0, 0.0)),
            base_polygon: vec![v2(0.15, 0.15), v2(-0.15, 0.15), v2(-0.15, -0.15)],
            bounding_box_section: vec![],
        }),
        candidate: vec![detected_stationary_object::CandidateStationaryObject {
            probability: Some(1.0),
            classification: Some(stationary_object::Classification {
                r#type: Some(stationary_object::classification::Type::Pole as i32),
                material: Some(stationary_object::classification::Material::Metal as i32),
                density: Some(stationary_object::classification::Density::Solid as i32),
                color: Some(stationary_object::classification::Color::Gray as i32),
                assigned_lane_id: vec![id(0), id(5)],
                assigned_lane_percentage: vec![0.0, -1.5, 100.0],
                ..Default::default()
            }),
        }],
        radar_specifics: Some(RadarSpecificObjectData { rcs: Some(10.0) }),
        ..Default::default()
    }];

    let radar = RadarDetectionData {
        header: Some(detection_header(2)),
        detection: vec![
            RadarDetection {
                existence_probability: Some(0.99),
                object_id: Some(id(0)),
                position: Some(sph(30.0, -0.05, 0.01)),
                position_rmse: Some(sph(0.1, 0.002, 0.004)),
                radial_velocity: Some(-2.5),
                radial_velocity_rmse: Some(0.05),
                rcs: Some(-3.25),
                snr: Some(21.5),
                point_target_probability: Some(0.0),
                ambiguity_id: Some(id(0)),
                classification: Some(DetectionClassification::Clutter as i32),
            },
            RadarDetection {
                object_id: Some(id(u64::MAX)),
                position: Some(sph(150.0, 0.7, -0.02)),
                radial_velocity: Some(13.9),
                rcs: Some(5.0),
                classification: Some(DetectionClassification::Unknown as i32),
                ..Default::default()
            },
        ],
    };

    let lidar = LidarDetectionData {
        header: Some(detection_header(2)),
        detection: vec![
            LidarDetection {
                existence_probability: Some(1.0),
                object_id: Some(id(42)),
                position: Some(sph(25.5, 0.1, -0.02)),
                position_rmse: Some(sph(0.02, 0.001, 0.001)),
                height: Some(0.5),
                height_rmse: Some(0.01),
                intensity: Some(37.5),
                free_space_probability: Some(0.0),
                classification: Some(DetectionClassification::Underdrivable as i32),
                reflectivity: Some(0.12),
                echo_pulse_width: Some(3.5e-9),
                radial_velocity: Some(-0.75),
                beam_id: Some(id(63)),
            },
            LidarDetection {
                position: Some(sph(1e-3, -3.0, 0.5)),
                intensity: Some(0.0),
                beam_id: Some(id(0)),
                ..Default::default()
            },
        ],
    };

    let camera = CameraDetectionData {
        header: Some(detection_header(1)),
        specific_header: Some(CameraDetectionSpecificHeader {
            number_of_valid_points: Some(4),
        }),
        detection: vec![CameraDetection {
            existence_probability: Some(0.8),
            object_id: Some(id(0)),
            time_difference: Some(ts(0, 1_000_000)),
            image_shape_type: Some(camera_detection::ImageShapeType::Box as i32),
            shape_classification_background: Some(false),
            shape_classification_moving_object: Some(true),
            shape_classification_vehicle: Some(true),
            shape_classification_pedestrian_rear: Some(false),
            shape_classification_probability: Some(0.75),
            color: Some(camera_detection::Color::Red as i32),
            color_probability: Some(0.6),
            ambiguity_id: Some(id(2)),
            first_point_index: Some(0),
            number_of_points: Some(4),
            color_description: Some(ColorDescription {
                grey: Some(ColorGrey { grey: Some(0.5) }),
                ..Default::default()
            }),
            ..Default::default()
        }],
        point: [(-0.1, 0.02), (0.1, 0.02), (0.1, -0.02), (-0.1, -0.02)]
            .iter()
            .map(|&(az, el)| CameraPoint {
                existence_probability: Some(1.0),
                point: Some(sph(30.0, az, el)),
                point_rmse: Some(sph(0.0, 0.001, 0.001)),
            })
            .collect(),
    };

    let ultrasonic = UltrasonicDetectionData {
        header: Some(detection_header(1)),
        specific_header: Some(UltrasonicDetectionSpecificHeader {
            max_range: Some(5.0),
            number_of_valid_indirect_detections: Some(1),
        }),
        detection: vec![UltrasonicDetection {
            existence_probability: Some(1.0),
            object_id: Some(id(0)),
            distance: Some(2.5),
        }],
        indirect_detection: vec![UltrasonicIndirectDetection {
            existence_probability: Some(0.5),
            object_id: Some(id(0)),
            ellipsoid_radial: Some(1.0),
            ellipsoid_axial: Some(0.5),
            receiver_id: Some(id(1)),
            receiver_origin: Some(v3(-0.1, 0.2, 0.3)),
        }],
    };

    SensorData {
        version: Some(version()),
        timestamp: Some(ts(12, 345_000_000)),
        host_vehicle_location: Some(BaseMoving {
            dimension: Some(d3(4.5, 1.8, 1.4)),
            position: Some(v3(-1234.5, 987.25, -0.5)),
            orientation: Some(o3(0.0, 0.0, -1.5)),
            velocity: Some(v3(-13.9, 0.1, 0.0)),
            acceleration: Some(v3(-0.5, 0.0, 0.0)),
            orientation_rate: Some(o3(0.0, 0.0, -0.01)),
            orientation_acceleration: Some(o3(0.0, 0.0, 0.001)),
            base_polygon: vec![v2(2.25, 0.9), v2(-2.25, 0.9), v2(-2.25, -0.9)],
            bounding_box_section: vec![BoundingBox {
                dimension: Some(d3(0.2, 0.25, 0.15)),
                position: Some(v3(0.9, 1.0, 0.3)),
                orientation: Some(o3(0.0, 0.0, 0.0)),
                contained_object_type: Some(bounding_box::Type::SideMirror as i32),
                model_reference: Some("mirror_L.glb".into()),
            }],
        }),
        host_vehicle_location_rmse: Some(BaseMoving {
            position: Some(v3(0.1, 0.1, 0.2)),
            ..Default::default()
        }),
        sensor_id: Some(id(0)),
        mounting_position: Some(sensor_mounting()),
        mounting_position_rmse: Some(sensor_mounting_rmse()),
        sensor_view: vec![SensorView {
            version: Some(version()),
            timestamp: Some(ts(12, 345_000_000)),
            sensor_id: Some(id(0)),
            host_vehicle_id: Some(id(0)),
            ..Default::default()
        }],
        last_measurement_time: Some(ts(12, 300_000_000)),
        stationary_object_header: Some(entity_header(u64::MAX, Dq::Blindness)),
        stationary_object: stationary,
        moving_object_header: Some(entity_header(0, Dq::Available)),
        moving_object: moving,
        traffic_sign_header: Some(entity_header(1, Dq::NotAvailable)),
        traffic_sign: vec![rich_detected_traffic_sign()],
        traffic_light_header: Some(entity_header(3, Dq::Available)),
        traffic_light: vec![DetectedTrafficLight {
            header: Some(DetectedItemHeader {
                tracking_id: Some(id(78)),
                ground_truth_id: vec![id(78)],
                ..Default::default()
            }),
            base: Some(BaseStationary {
                dimension: Some(d3(0.05, 0.2, 0.2)),
                position: Some(v3(59.0, 3.1, 4.0)),
                ..Default::default()
            }),
            candidate: vec![detected_traffic_light::CandidateTrafficLight {
                probability: Some(1.0),
                classification: Some(traffic_light::Classification {
                    color: Some(traffic_light::classification::Color::Red as i32),
                    mode: Some(traffic_light::classification::Mode::Off as i32),
                    counter: Some(0.0),
                    ..Default::default()
                }),
            }],
            ..Default::default()
        }],
        road_marking_header: Some(entity_header(4, Dq::AvailableReduced)),
        road_marking: vec![DetectedRoadMarking {
            header: Some(DetectedItemHeader {
                tracking_id: Some(id(79)),
                ground_truth_id: vec![id(79)],
                ..Default::default()
            }),
            base: Some(BaseStationary {
                position: Some(v3(49.0, 0.1, -1.5)),
                ..Default::default()
            }),
            candidate: vec![detected_road_marking::CandidateRoadMarking {
                probability: Some(0.9),
                classification: Some(road_marking::Classification {
                    r#type: Some(road_marking::classification::Type::GenericLine as i32),
                    monochrome_color: Some(road_marking::classification::Color::White as i32),
                    ..Default::default()
                }),
            }],
            ..Default::default()
        }],
        lane_boundary_header: Some(entity_header(2, Dq::Unknown)),
        lane_boundary: vec![DetectedLaneBoundary {
            header: Some(DetectedItemHeader {
                tracking_id: Some(id(300)),
                ground_truth_id: vec![id(300)],
                existence_probability: Some(0.75),
                ..Default::default()
            }),
            candidate: vec![detected_lane_boundary::CandidateLaneBoundary {
                probability: Some(1.0),
                classification: Some(lane_boundary::Classification {
                    r#type: Some(lane_boundary::classification::Type::DashedLine as i32),
                    color: Some(lane_boundary::classification::Color::White as i32),
                    ..Default::default()
                }),
            }],
            boundary_line: vec![
                lane_boundary::BoundaryPoint {
                    position: Some(v3(6.0, 1.75, -1.5)),
                    width: Some(0.12),
                    ..Default::default()
                },
                lane_boundary::BoundaryPoint {
                    position: Some(v3(8.0, 1.74, -1.5)),
                    dash: Some(lane_boundary::boundary_point::Dash::End as i32),
                    ..Default::default()
                },
            ],
            boundary_line_confidences: vec![0.9, 0.0],
            ..Default::default()
        }],
        feature_data: Some(FeatureData {
            version: Some(version()),
            radar_sensor: vec![radar],
            lidar_sensor: vec![lidar],
            ultrasonic_sensor: vec![ultrasonic],
            camera_sensor: vec![camera],
        }),
        logical_detection_data: Some(LogicalDetectionData {
            version: Some(version()),
            header: Some(LogicalDetectionDataHeader {
                logical_detection_time: Some(ts(12, 300_000_000)),
                data_qualifier: Some(
                    logical_detection_data_header::DataQualifier::Available as i32,
                ),
                number_of_valid_logical_detections: Some(1),
                sensor_id: vec![id(0)],
            }),
            logical_detection: vec![LogicalDetection {
                existence_probability: Some(0.9),
                object_id: Some(id(42)),
                position: Some(v3(26.0, -0.4, 0.5)),
                position_rmse: Some(v3(0.1, 0.1, 0.1)),
                velocity: Some(v3(-2.5, 0.0, 0.0)),
                velocity_rmse: Some(v3(0.05, 0.05, 0.05)),
                intensity: Some(40.0),
                snr: Some(12.0),
                point_target_probability: Some(0.1),
                sensor_id: vec![id(0), id(1)],
                classification: Some(LogicalDetectionClassification::Overdrivable as i32),
                echo_pulse_width: Some(4e-9),
            }],
        }),
        virtual_detection_area: Some(sensor_data::VirtualDetectionArea {
            polygon: vec![Polygon3d {
                vertex: vec![
                    v3(0.0, 0.0, 0.0),
                    v3(200.0, -100.0, 0.0),
                    v3(200.0, 100.0, 0.0),
                ],
            }],
        }),
        system_time: Some(ts(-3, 999_999_999)),
        ..Default::default()
    }
}

/// The detected speed-limit sign of [`rich_sensor_data`] (mirrored in the Python test).
fn rich_detected_traffic_sign() -> DetectedTrafficSign {
    use detected_traffic_sign::{DetectedMainSign, DetectedSupplementarySign, detected_main_sign};
    use traffic_sign::{main_sign, supplementary_sign};
    DetectedTrafficSign {
        header: Some(DetectedItemHeader {
            tracking_id: Some(id(77)),
            ground_truth_id: vec![id(77)],
            existence_probability: Some(0.8),
            age: Some(0.0),
            ..Default::default()
        }),
        main_sign: Some(DetectedMainSign {
            candidate: vec![detected_main_sign::CandidateMainSign {
                probability: Some(1.0),
                classification: Some(main_sign::Classification {
                    r#type: Some(main_sign::classification::Type::SpeedLimitBegin as i32),
                    value: Some(TrafficSignValue {
                        value: Some(50.0),
                        value_unit: Some(traffic_sign_value::Unit::KilometerPerHour as i32),
                        text: None,
                    }),
                    ..Default::default()
                }),
            }],
            base: Some(BaseStationary {
                dimension: Some(d3(0.02, 0.6, 0.6)),
                position: Some(v3(39.5, -4.4, 0.8)),
                ..Default::default()
            }),
            base_rmse: None,
            geometry: Some(detected_main_sign::Geometry::Circle as i32),
        }),
        supplementary_sign: vec![DetectedSupplementarySign {
            candidate: vec![
                detected_traffic_sign::detected_supplementary_sign::CandidateSupplementarySign {
                    probability: Some(0.5),
                    classification: Some(supplementary_sign::Classification {
                        r#type: Some(supplementary_sign::classification::Type::Time as i32),
                        ..Default::default()
                    }),
                },
            ],
            base: None,
            base_rmse: None,
        }],
    }
}

/// Small messages whose bytes must equal osi3's serialization exactly.
fn golden_messages() -> Vec<(&'static str, Vec<u8>)> {
    use camera_sensor_view_configuration::{ChannelFormat, PixelOrder};
    use environmental_conditions as env;
    use moving_object::vehicle_classification::light_state::{self as ls, GenericLightState};
    vec![
        ("identifier_zero", id(0).encode_to_vec()),
        ("identifier_max", id(u64::MAX).encode_to_vec()),
        ("timestamp_zero", ts(0, 0).encode_to_vec()),
        ("timestamp_negative", ts(-1, 500_000_000).encode_to_vec()),
        ("interface_version", version().encode_to_vec()),
        (
            "mounting_position",
            mp(v3(-1.25, 0.0, 1e-300), o3(-0.0, PI, -2.5)).encode_to_vec(),
        ),
        (
            "base_moving_out_of_order",
            BaseMoving {
                dimension: Some(d3(4.0, 2.0, 1.5)),
                orientation_acceleration: Some(o3(0.0, 0.0, -0.5)),
                base_polygon: vec![v2(1.0, -1.0), v2(-1.0, -1.0)],
                bounding_box_section: vec![BoundingBox {
                    contained_object_type: Some(bounding_box::Type::Cargo as i32),
                    ..Default::default()
                }],
                ..Default::default()
            }
            .encode_to_vec(),
        ),
        (
            "light_state",
            moving_object::vehicle_classification::LightState {
                indicator_state: Some(ls::IndicatorState::Warning as i32),
                head_light: Some(GenericLightState::On as i32),
                tail_light: Some(GenericLightState::Off as i32),
                brake_light_state: Some(ls::BrakeLightState::Strong as i32),
                service_vehicle_illumination: Some(GenericLightState::Unknown as i32),
                ..Default::default()
            }
            .encode_to_vec(),
        ),
        (
            "environmental_conditions",
            EnvironmentalConditions {
                ambient_illumination: Some(env::AmbientIllumination::Level9 as i32),
                time_of_day: Some(env::TimeOfDay {
                    seconds_since_midnight: Some(0),
                }),
                unix_timestamp: Some(-86_400),
                temperature: Some(253.15),
                precipitation: Some(env::Precipitation::Extreme as i32),
                fog: Some(env::Fog::Dense as i32),
                ..Default::default()
            }
            .encode_to_vec(),
        ),
        (
            "lidar_view_configuration",
            LidarSensorViewConfiguration {
                sensor_id: Some(id(0)),
                field_of_view_horizontal: Some(TAU),
                number_of_rays_horizontal: Some(0),
                num_of_pixels: Some(3),
                directions: vec![v3(1.0, 0.0, 0.0), v3(0.0, -1.0, 0.0)],
                timings: vec![0, 1, u32::MAX],
                ..Default::default()
            }
            .encode_to_vec(),
        ),
        (
            "camera_view_configuration",
            CameraSensorViewConfiguration {
                number_of_pixels_horizontal: Some(1920),
                number_of_pixels_vertical: Some(1080),
                channel_format: vec![
                    ChannelFormat::RgbU8Lin as i32,
                    ChannelFormat::MonoF32Lin as i32,
                    ChannelFormat::Other as i32,
                ],
                samples_per_pixel: Some(1),
                wavelength_data: vec![WavelengthData {
                    start: Some(380e-9),
                    end: Some(780e-9),
                    samples_number: Some(41.0),
                }],
                pixel_order: Some(PixelOrder::Default as i32),
                ..Default::default()
            }
            .encode_to_vec(),
        ),
        (
            "lidar_reflection",
            lidar_sensor_view::Reflection {
                signal_strength: Some(-80.5),
                time_of_flight: Some(2e-7),
                doppler_shift: Some(-1500.0),
                normal_to_surface: Some(v3(-1.0, 0.0, 0.0)),
                object_id: Some(id(0)),
            }
            .encode_to_vec(),
        ),
        (
            "stationary_classification",
            stationary_object::Classification {
                r#type: Some(stationary_object::classification::Type::EmittingStructure as i32),
                assigned_lane_id: vec![id(3), id(0)],
                assigned_lane_percentage: vec![50.0, -0.0, 1e300],
                ..Default::default()
            }
            .encode_to_vec(),
        ),
        (
            "sensor_view_configuration",
            SensorViewConfiguration {
                version: Some(version()),
                sensor_id: Some(id(0)),
                mounting_position: Some(sensor_mounting()),
                field_of_view_horizontal: Some(FRAC_PI_2),
                field_of_view_vertical: Some(0.17453292519943295),
                range: Some(200.0),
                update_cycle_time: Some(ts(0, 50_000_000)),
                update_cycle_offset: Some(ts(0, 0)),
                simulation_start_time: Some(ts(-10, 0)),
                omit_static_information: Some(false),
                radar_sensor_view_configuration: vec![RadarSensorViewConfiguration {
                    sensor_id: Some(id(0)),
                    mounting_position: Some(sensor_mounting()),
                    field_of_view_horizontal: Some(FRAC_PI_2),
                    field_of_view_vertical: Some(0.17453292519943295),
                    number_of_rays_horizontal: Some(512),
                    number_of_rays_vertical: Some(16),
                    max_number_of_interactions: Some(3),
                    emitter_frequency: Some(77e9),
                    tx_antenna_diagram: vec![
                        radar_sensor_view_configuration::AntennaDiagramEntry {
                            horizontal_angle: Some(-0.5),
                            vertical_angle: Some(0.0),
                            response: Some(-3.0),
                        },
                    ],
                    rx_antenna_diagram: vec![],
                    ..Default::default()
                }],
                ..Default::default()
            }
            .encode_to_vec(),
        ),
        (
            "sensor_data_minimal",
            SensorData {
                version: Some(version()),
                timestamp: Some(ts(0, 0)),
                sensor_id: Some(id(0)),
                mounting_position: Some(sensor_mounting()),
                ..Default::default()
            }
            .encode_to_vec(),
        ),
        ("sensor_data_empty", SensorData::default().encode_to_vec()),
    ]
}

fn write_golden(dir: &str) -> Result<()> {
    let dir = Path::new(dir);
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for (name, bytes) in golden_messages() {
        let path = dir.join(format!("{name}.pb"));
        std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
