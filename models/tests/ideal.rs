//! Closed-form behaviour tests of the ideal object-level model (`osiris_models::ideal`).

mod common;
use common::v3;
use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec3;
use osiris_models::frames::{Spherical, rotation_from_rpy};
use osiris_models::ideal::IdealSensor;
use osiris_models::sensor::Mounting;
use osiris_models::{SensorConfig, SensorKind, SensorModel, StepInput, StepOutput};
use osiris_proto::{id, osi3, timestamp_from_seconds};

const HOST: u64 = 1;

fn vehicle(oid: u64, pos: [f64; 3], yaw: f64, dim: [f64; 3], vel: [f64; 3]) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(dim[0]),
                width: Some(dim[1]),
                height: Some(dim[2]),
            }),
            position: Some(v3(pos)),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(yaw),
            }),
            velocity: Some(v3(vel)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        vehicle_classification: Some(osi3::moving_object::VehicleClassification {
            r#type: Some(osi3::moving_object::vehicle_classification::Type::Car as i32),
            ..Default::default()
        }),
        model_reference: Some("osiris:car".into()),
        ..Default::default()
    }
}

fn car(oid: u64, pos: [f64; 3]) -> osi3::MovingObject {
    vehicle(oid, pos, 0.0, [4.5, 1.8, 1.5], [0.0; 3])
}

fn wall(oid: u64, pos: [f64; 3], dim: [f64; 3]) -> osi3::StationaryObject {
    osi3::StationaryObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(osi3::Dimension3d {
                length: Some(dim[0]),
                width: Some(dim[1]),
                height: Some(dim[2]),
            }),
            position: Some(v3(pos)),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(0.0),
            }),
            ..Default::default()
        }),
        classification: Some(osi3::stationary_object::Classification {
            r#type: Some(osi3::stationary_object::classification::Type::Wall as i32),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// A SensorView; `host` (if any) is added to the moving objects and named in the SensorView.
fn view(
    host: Option<osi3::MovingObject>,
    moving: Vec<osi3::MovingObject>,
    stationary: Vec<osi3::StationaryObject>,
    mounting: Mounting,
    t: f64,
) -> osi3::SensorView {
    let host_id = host.as_ref().and_then(|h| h.id);
    let mut all = Vec::new();
    all.extend(host);
    all.extend(moving);
    osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(timestamp_from_seconds(t)),
        sensor_id: Some(id(42)),
        mounting_position: Some(mounting.to_osi()),
        host_vehicle_id: host_id,
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(timestamp_from_seconds(t)),
            host_vehicle_id: host_id,
            moving_object: all,
            stationary_object: stationary,
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn at_origin() -> Mounting {
    Mounting {
        position_m: [0.0; 3],
        orientation_rad: [0.0; 3],
    }
}

fn config(kind: SensorKind) -> SensorConfig {
    let mut c = SensorConfig::default_for(kind);
    c.mounting = at_origin();
    c
}

fn run(sensor: &mut IdealSensor, v: &osi3::SensorView) -> StepOutput {
    let mut out = StepOutput::default();
    sensor
        .step(
            &StepInput {
                view: v,
                time_s: 0.0,
                step_s: 0.05,
            },
            &mut out,
        )
        .expect("step");
    out
}

fn moving_ids(out: &StepOutput) -> Vec<u64> {
    out.sensor_data
        .moving_object
        .iter()
        .map(|o| {
            o.header
                .as_ref()
                .unwrap()
                .tracking_id
                .unwrap()
                .value
                .unwrap()
        })
        .collect()
}

fn radar_dets(out: &StepOutput) -> &[osi3::RadarDetection] {
    &out.sensor_data.feature_data.as_ref().unwrap().radar_sensor[0].detection
}

fn sph(s: &Option<osi3::Spherical3d>) -> Spherical {
    Spherical::from_osi(s.as_ref().unwrap())
}

#[test]
fn object_straight_ahead_is_detected_at_its_closest_point() {
    let mut s = IdealSensor::new(config(SensorKind::Radar));
    let out = run(
        &mut s,
        &view(
            None,
            vec![car(7, [50.0, 0.0, 0.0])],
            vec![],
            at_origin(),
            1.0,
        ),
    );
    assert_eq!(moving_ids(&out), vec![7]);
    let o = &out.sensor_data.moving_object[0];
    let pos = o.base.as_ref().unwrap().position.unwrap();
    assert_eq!((pos.x, pos.y, pos.z), (Some(50.0), Some(0.0), Some(0.0)));
    let h = o.header.as_ref().unwrap();
    assert_eq!(h.existence_probability, Some(1.0));
    assert_eq!(h.ground_truth_id, vec![id(7)]);
    assert_eq!(
        h.measurement_state,
        Some(osi3::detected_item_header::MeasurementState::Measured as i32)
    );
    assert_eq!(
        o.reference_point,
        Some(osi3::detected_moving_object::ReferencePoint::Center as i32)
    );
    assert_eq!(
        o.candidate[0].r#type,
        Some(osi3::moving_object::Type::Vehicle as i32)
    );
    assert_eq!(
        o.candidate[0]
            .vehicle_classification
            .as_ref()
            .unwrap()
            .r#type,
        Some(4)
    );
    let d = radar_dets(&out);
    assert_eq!(d.len(), 1);
    let p = sph(&d[0].position);
    assert!((p.distance - (50.0 - 2.25)).abs() < 1e-12, "{p:?}");
    assert!(p.azimuth.abs() < 1e-12 && p.elevation.abs() < 1e-12);
    assert_eq!(d[0].object_id, Some(id(7)));
    assert_eq!(d[0].rcs, Some(10.0));
    // snr = 10 − 40 log10(47.75) + 90.
    assert!((d[0].snr.unwrap() - (100.0 - 40.0 * 47.75f64.log10())).abs() < 1e-9);
    // Perception mirrors it.
    let peak = &out.perception.radar.as_ref().unwrap().peak[0];
    assert_eq!(peak.range_m, Some(p.distance));
    assert_eq!(out.perception.model_mode.as_deref(), Some("ideal"));
}

#[test]
fn field_of_view_edges() {
    // Radar FoV 90°: a 2 m cube at range r subtends ±asin(√3/r) around its centre direction.
    let cube = |oid, r: f64, az: f64| {
        vehicle(
            oid,
            [r * az.cos(), r * az.sin(), 0.0],
            0.0,
            [2.0; 3],
            [0.0; 3],
        )
    };
    let margin = |r: f64| (3f64.sqrt() / r).asin();
    let half = 45f64.to_radians();
    let mut s = IdealSensor::new(config(SensorKind::Radar));
    let out = run(
        &mut s,
        &view(
            None,
            vec![
                cube(1, 50.0, half - 0.5 * margin(50.0)),  // centre inside
                cube(2, 50.0, -half - 0.5 * margin(50.0)), // centre outside, a corner region inside
                cube(3, 80.0, half + margin(80.0) + 0.01), // entirely outside
                cube(4, 80.0, -half - margin(80.0) - 0.01),
            ],
            vec![],
            at_origin(),
            0.0,
        ),
    );
    assert_eq!(moving_ids(&out), vec![1, 2]);
    // Every radar detection lies inside the FoV.
    for d in radar_dets(&out) {
        assert!(sph(&d.position).azimuth.abs() <= half + 1e-12);
    }
}

#[test]
fn objects_behind_or_beyond_range_are_not_detected() {
    let mut s = IdealSensor::new(config(SensorKind::Camera)); // range 150 m, FoV 60°
    let out = run(
        &mut s,
        &view(
            None,
            vec![
                car(1, [-30.0, 0.0, 0.0]),
                car(2, [150.0 + 2.25 + 2.0, 5.0, 0.0]),
                car(3, [150.0 + 2.0, 0.0, 0.0]),
            ],
            vec![],
            at_origin(),
            0.0,
        ),
    );
    // Car 3's rear face (x = 149.75) is in range; car 2's closest point (152, 4.1) is not.
    assert_eq!(moving_ids(&out), vec![3]);
}

#[test]
fn occlusion_full_and_partial() {
    let mut c = config(SensorKind::Radar);
    c.min_visible_fraction = 0.1;
    let mut s = IdealSensor::new(c);
    // A 10×3×4 truck at 20 m fully hides a car at 50 m directly behind it.
    let truck = vehicle(10, [20.0, 0.0, 0.0], 0.0, [10.0, 3.0, 4.0], [0.0; 3]);
    let out = run(
        &mut s,
        &view(
            None,
            vec![truck.clone(), car(11, [50.0, 0.0, 0.0])],
            vec![],
            at_origin(),
            0.0,
        ),
    );
    assert_eq!(moving_ids(&out), vec![10]);

    // A wall covering y ∈ [−3, 0] at x = 20 hides the right half of a car at 50 m.
    let out = run(
        &mut s,
        &view(
            None,
            vec![car(11, [50.0, 0.0, 0.0])],
            vec![wall(12, [20.0, -1.5, 0.0], [0.2, 3.0, 4.0])],
            at_origin(),
            0.0,
        ),
    );
    assert_eq!(moving_ids(&out), vec![11]);
    let f = s
        .visible_fractions()
        .into_iter()
        .find(|(i, _)| *i == 11)
        .unwrap()
        .1;
    assert!(f > 0.0 && f < 1.0, "fraction {f}");
    let p = out.sensor_data.moving_object[0]
        .header
        .as_ref()
        .unwrap()
        .existence_probability
        .unwrap();
    assert!(p > 0.5 && p < 1.0, "existence {p}");
    // The radar detection point is seen: it lies on the left (unoccluded) side.
    let d = sph(&radar_dets(&out)
        .iter()
        .find(|d| d.object_id == Some(id(11)))
        .unwrap()
        .position);
    assert!(d.azimuth > 0.0);

    // With a threshold above the visible fraction the car disappears.
    let mut c = config(SensorKind::Radar);
    c.min_visible_fraction = 0.9;
    let mut s = IdealSensor::new(c);
    let out = run(
        &mut s,
        &view(
            None,
            vec![car(11, [50.0, 0.0, 0.0])],
            vec![wall(12, [20.0, -1.5, 0.0], [0.2, 3.0, 4.0])],
            at_origin(),
            0.0,
        ),
    );
    assert!(moving_ids(&out).is_empty());
}

fn host_car(pos: [f64; 3], yaw: f64, vel: [f64; 3]) -> osi3::MovingObject {
    let mut h = vehicle(HOST, pos, yaw, [4.5, 1.8, 1.5], vel);
    h.vehicle_attributes = Some(osi3::moving_object::VehicleAttributes {
        bbcenter_to_rear: Some(v3([-1.4, 0.0, -0.4])),
        ..Default::default()
    });
    h
}

#[test]
fn host_vehicle_is_never_detected() {
    // Host box centre (1.4, 0, 0.75) → rear axle at (0, 0, 0.35); the sensor 2 m ahead of it and 0.5 m
    // up is inside the host box. A car 30 m ahead must be seen through the host's own box.
    let mount = Mounting {
        position_m: [2.0, 0.0, 0.5],
        orientation_rad: [0.0; 3],
    };
    let mut s = IdealSensor::new(config(SensorKind::Lidar));
    let host = host_car([1.4, 0.0, 0.75], 0.0, [0.0; 3]);
    let v = view(
        Some(host.clone()),
        vec![car(5, [32.0, 0.0, 0.75])],
        vec![],
        mount,
        0.0,
    );
    let out = run(&mut s, &v);
    assert_eq!(moving_ids(&out), vec![5]);
    let loc = out.sensor_data.host_vehicle_location.as_ref().unwrap();
    assert_eq!(loc.position.unwrap().x, Some(1.4));

    // Host id only in the ground truth.
    let mut v2 = v.clone();
    v2.host_vehicle_id = None;
    assert_eq!(moving_ids(&run(&mut s, &v2)), vec![5]);

    // No host id at all: the box containing the sensor is still neither reported nor an occluder.
    let mut v3 = v.clone();
    v3.host_vehicle_id = None;
    v3.global_ground_truth.as_mut().unwrap().host_vehicle_id = None;
    assert_eq!(moving_ids(&run(&mut s, &v3)), vec![5]);

    // A host id that is missing from the ground truth is an input error.
    let mut v4 = v.clone();
    v4.host_vehicle_id = Some(id(99));
    let mut out = StepOutput::default();
    assert!(
        s.step(
            &StepInput {
                view: &v4,
                time_s: 0.0,
                step_s: 0.1
            },
            &mut out
        )
        .is_err()
    );
    // So is a SensorView without ground truth.
    let v5 = osi3::SensorView::default();
    assert!(
        s.step(
            &StepInput {
                view: &v5,
                time_s: 0.0,
                step_s: 0.1
            },
            &mut out
        )
        .is_err()
    );
}

#[test]
fn radial_velocity_sign_follows_osi() {
    let mut s = IdealSensor::new(config(SensorKind::Radar));
    // Ego at rest (no host); target approaching at 5 m/s, another receding at 3 m/s.
    let approaching = vehicle(1, [40.0, 0.0, 0.0], 0.0, [4.5, 1.8, 1.5], [-5.0, 0.0, 0.0]);
    let receding = vehicle(
        2,
        [60.0, 20.0, 0.0],
        0.0,
        [4.5, 1.8, 1.5],
        [3.0 * 60.0 / 63.245553, 3.0 * 20.0 / 63.245553, 0.0],
    );
    let out = run(
        &mut s,
        &view(None, vec![approaching, receding], vec![], at_origin(), 0.0),
    );
    let d = radar_dets(&out);
    let rv = |oid| {
        d.iter()
            .find(|d| d.object_id == Some(id(oid)))
            .unwrap()
            .radial_velocity
            .unwrap()
    };
    assert!((rv(1) - 5.0).abs() < 1e-9, "{}", rv(1));
    assert!(rv(2) < -2.9 && rv(2) > -3.0, "{}", rv(2)); // detection point slightly off the centre line
    let peaks = &out.perception.radar.as_ref().unwrap().peak;
    for (p, d) in peaks.iter().zip(d) {
        assert_eq!(p.range_rate_m_s, d.radial_velocity.map(|v| -v));
    }

    // Ego driving +x at 10 m/s towards a stationary wall: the wall approaches at 10 m/s.
    let host = host_car([1.4, 0.0, 0.75], 0.0, [10.0, 0.0, 0.0]);
    let mount = Mounting {
        position_m: [3.7, 0.0, 0.4],
        orientation_rad: [0.0; 3],
    };
    let out = run(
        &mut s,
        &view(
            Some(host),
            vec![],
            vec![wall(3, [60.0, 0.0, 0.75], [0.5, 4.0, 1.5])],
            mount,
            0.0,
        ),
    );
    let d = radar_dets(&out);
    assert_eq!(d.len(), 1);
    assert!((d[0].radial_velocity.unwrap() - 10.0).abs() < 1e-9);
    // The detected object's velocity is relative: a stationary wall moves at −10 m/s in the sensor frame
    // (stationary objects carry no velocity in OSI; check with a parked car instead).
    let host = host_car([1.4, 0.0, 0.75], 0.0, [10.0, 0.0, 0.0]);
    let parked = vehicle(4, [60.0, 0.0, 0.75], 0.0, [4.5, 1.8, 1.5], [0.0; 3]);
    let out = run(&mut s, &view(Some(host), vec![parked], vec![], mount, 0.0));
    let vel = out.sensor_data.moving_object[0]
        .base
        .as_ref()
        .unwrap()
        .velocity
        .unwrap();
    assert!((vel.x.unwrap() + 10.0).abs() < 1e-9 && vel.y.unwrap().abs() < 1e-9);
    assert_eq!(
        out.sensor_data.moving_object[0].movement_state,
        Some(osi3::detected_moving_object::MovementState::Stationary as i32)
    );
}

#[test]
fn yawed_mount_sees_the_left_side_straight_ahead() {
    // Sensor on the rear axle 1 m up, yawed 90° to the left; a car 20 m to the vehicle's left.
    let mount = Mounting {
        position_m: [0.0, 0.0, 1.0],
        orientation_rad: [0.0, 0.0, FRAC_PI_2],
    };
    let host = host_car([1.4, 0.0, 0.75], 0.0, [0.0; 3]);
    // Rear axle at (0, 0, 0.35); sensor at (0, 0, 1.35); target centre at the sensor height.
    let target = car(9, [0.0, 20.0, 1.35]);
    let mut s = IdealSensor::new(config(SensorKind::Radar));
    let out = run(&mut s, &view(Some(host), vec![target], vec![], mount, 0.0));
    assert_eq!(moving_ids(&out), vec![9]);
    let d = sph(&radar_dets(&out)[0].position);
    assert!(
        d.azimuth.abs() < 1e-12 && d.elevation.abs() < 1e-12,
        "{d:?}"
    );
    assert!((d.distance - (20.0 - 0.9)).abs() < 1e-12);
    // The car heads along the vehicle's +x = the sensor's −y: relative yaw −90°.
    let o = out.sensor_data.moving_object[0]
        .base
        .as_ref()
        .unwrap()
        .orientation
        .unwrap();
    assert!((o.yaw.unwrap() + FRAC_PI_2).abs() < 1e-12);
    let pos = out.sensor_data.moving_object[0]
        .base
        .as_ref()
        .unwrap()
        .position
        .unwrap();
    assert!((pos.x.unwrap() - 20.0).abs() < 1e-12 && pos.y.unwrap().abs() < 1e-12);
}

fn surface_distance(p: DVec3, centre: DVec3, yaw: f64, dim: [f64; 3]) -> f64 {
    let l = rotation_from_rpy(0.0, 0.0, yaw).transpose() * (p - centre);
    let h = DVec3::from(dim) * 0.5;
    let q = l.abs() - h;
    if q.max_element() <= 0.0 {
        -q.max_element()
    } else {
        q.max(DVec3::ZERO).length()
    }
}

#[test]
fn lidar_points_lie_on_the_box_faces() {
    let mut s = IdealSensor::new(config(SensorKind::Lidar));
    let yaw = 0.6;
    let dim = [4.5, 1.8, 1.5];
    let centre = DVec3::new(25.0, 8.0, -0.5);
    let obj = vehicle(3, centre.to_array(), yaw, dim, [0.0; 3]);
    let out = run(&mut s, &view(None, vec![obj], vec![], at_origin(), 2.5));
    let data = &out.sensor_data.feature_data.as_ref().unwrap().lidar_sensor[0];
    assert!(data.detection.len() >= 9);
    assert_eq!(
        data.header.as_ref().unwrap().number_of_valid_detections,
        Some(data.detection.len() as u32)
    );
    for d in &data.detection {
        let p = sph(&d.position).to_cartesian();
        assert!(surface_distance(p, centre, yaw, dim) < 1e-9, "{p}");
        assert_eq!(d.object_id, Some(id(3)));
        assert_eq!(d.intensity, Some(50.0));
        assert!(d.beam_id.is_none());
    }
    let cloud = out.perception.lidar.as_ref().unwrap();
    assert_eq!(cloud.x_m.len(), data.detection.len());
    assert_eq!(cloud.object_id.len(), data.detection.len());
    assert!(cloud.timestamp_ns.iter().all(|&t| t == 2_500_000_000));
    assert_eq!(cloud.wavelength_nm, Some(905.0));
    assert!(cloud.pulses_fired.unwrap() >= data.detection.len() as u64);
    assert_eq!(
        cloud.intensity_scale,
        Some(osiris_proto::perception::lidar_perception::IntensityScale::Percent as i32)
    );
}

#[test]
fn camera_box_corners_project_inside_the_fov() {
    let mut s = IdealSensor::new(config(SensorKind::Camera));
    let target = vehicle(4, [30.0, 3.0, 0.0], 0.3, [4.5, 1.8, 1.5], [0.0; 3]);
    let ped = osi3::MovingObject {
        r#type: Some(osi3::moving_object::Type::Pedestrian as i32),
        vehicle_classification: None,
        ..vehicle(5, [20.0, -4.0, 0.0], 0.0, [0.5, 0.6, 1.8], [0.0; 3])
    };
    let out = run(
        &mut s,
        &view(None, vec![target, ped], vec![], at_origin(), 0.0),
    );
    let cam = &out.sensor_data.feature_data.as_ref().unwrap().camera_sensor[0];
    assert_eq!(cam.detection.len(), 2);
    // OSI 3.8.0 box: 2 points (first and third corner of an axis-aligned box).
    assert_eq!(cam.point.len(), 4);
    assert_eq!(
        cam.specific_header.as_ref().unwrap().number_of_valid_points,
        Some(4)
    );
    let (hh, hv) = (30f64.to_radians(), 20f64.to_radians());
    for d in &cam.detection {
        assert_eq!(
            d.image_shape_type,
            Some(osi3::camera_detection::ImageShapeType::Box as i32)
        );
        assert_eq!(d.number_of_points, Some(2));
        let first = d.first_point_index.unwrap() as usize;
        for p in &cam.point[first..first + 2] {
            let q = sph(&p.point);
            assert!(q.azimuth.abs() < hh && q.elevation.abs() < hv, "{q:?}");
        }
        let is_ped = d.object_id == Some(id(5));
        assert_eq!(d.shape_classification_pedestrian, Some(is_ped));
        assert_eq!(d.shape_classification_vehicle, Some(!is_ped));
    }
    // The car's top-left point: the largest azimuth and elevation of its 8 corners; the
    // bottom-right one the smallest (sensor at the origin, so the corners' own spherical angles).
    let corner = |s: [f64; 3]| {
        Spherical::from_cartesian(
            DVec3::new(30.0, 3.0, 0.0)
                + rotation_from_rpy(0.0, 0.0, 0.3)
                    * (DVec3::new(2.25, 0.9, 0.75) * DVec3::from_array(s)),
        )
    };
    let mut az = Vec::new();
    let mut el = Vec::new();
    for k in 0..8 {
        let s = |b: usize| if k & b != 0 { 1.0 } else { -1.0 };
        let c = corner([s(4), s(2), s(1)]);
        az.push(c.azimuth);
        el.push(c.elevation);
    }
    let first = cam
        .detection
        .iter()
        .find(|d| d.object_id == Some(id(4)))
        .unwrap()
        .first_point_index
        .unwrap() as usize;
    let (p0, p1) = (
        sph(&cam.point[first].point),
        sph(&cam.point[first + 1].point),
    );
    let max = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    assert!((p0.azimuth - max(&az)).abs() < 1e-12 && (p0.elevation - max(&el)).abs() < 1e-12);
    assert!((p1.azimuth - min(&az)).abs() < 1e-12 && (p1.elevation - min(&el)).abs() < 1e-12);
    assert!(out.perception.camera.as_ref().unwrap().image.is_empty());
}

#[test]
fn stationary_objects_age_movement_and_reset() {
    let mut s = IdealSensor::new(config(SensorKind::Radar));
    let w = wall(20, [30.0, 0.0, 0.0], [0.5, 2.0, 1.0]);
    let moving = vehicle(21, [50.0, 5.0, 0.0], 0.0, [4.5, 1.8, 1.5], [1.0, 0.0, 0.0]);
    let mut out = StepOutput::default();
    for k in 0..3 {
        let v = view(
            None,
            vec![moving.clone()],
            vec![w.clone()],
            at_origin(),
            0.1 * k as f64,
        );
        s.step(
            &StepInput {
                view: &v,
                time_s: 0.1 * k as f64,
                step_s: 0.1,
            },
            &mut out,
        )
        .unwrap();
    }
    let st = &out.sensor_data.stationary_object;
    assert_eq!(st.len(), 1);
    let h = st[0].header.as_ref().unwrap();
    assert!((h.age.unwrap() - 0.2).abs() < 1e-9);
    assert_eq!(
        st[0].candidate[0].classification.as_ref().unwrap().r#type,
        Some(osi3::stationary_object::classification::Type::Wall as i32)
    );
    assert_eq!(st[0].radar_specifics.as_ref().unwrap().rcs, Some(20.0));
    assert_eq!(
        out.sensor_data
            .stationary_object_header
            .as_ref()
            .unwrap()
            .cycle_counter,
        Some(2)
    );
    assert_eq!(out.perception.cycle_counter, Some(2));
    let m = &out.sensor_data.moving_object[0];
    assert_eq!(
        m.movement_state,
        Some(osi3::detected_moving_object::MovementState::Moving as i32)
    );
    // The car stops: STOPPED, not STATIONARY.
    let mut stopped = moving.clone();
    stopped.base.as_mut().unwrap().velocity = Some(v3([0.0; 3]));
    let v = view(
        None,
        vec![stopped.clone()],
        vec![w.clone()],
        at_origin(),
        0.3,
    );
    s.step(
        &StepInput {
            view: &v,
            time_s: 0.3,
            step_s: 0.1,
        },
        &mut out,
    )
    .unwrap();
    assert_eq!(
        out.sensor_data.moving_object[0].movement_state,
        Some(osi3::detected_moving_object::MovementState::Stopped as i32)
    );
    // Out of sight for one cycle: the age restarts.
    let v = view(None, vec![], vec![], at_origin(), 0.4);
    s.step(
        &StepInput {
            view: &v,
            time_s: 0.4,
            step_s: 0.1,
        },
        &mut out,
    )
    .unwrap();
    assert!(out.sensor_data.stationary_object.is_empty());
    let v = view(None, vec![], vec![w.clone()], at_origin(), 0.5);
    s.step(
        &StepInput {
            view: &v,
            time_s: 0.5,
            step_s: 0.1,
        },
        &mut out,
    )
    .unwrap();
    assert_eq!(
        out.sensor_data.stationary_object[0]
            .header
            .as_ref()
            .unwrap()
            .age,
        Some(0.0)
    );
    // reset() restarts the cycle counter.
    s.reset();
    s.step(
        &StepInput {
            view: &v,
            time_s: 0.5,
            step_s: 0.1,
        },
        &mut out,
    )
    .unwrap();
    assert_eq!(
        out.sensor_data
            .moving_object_header
            .as_ref()
            .unwrap()
            .cycle_counter,
        Some(0)
    );
}

#[test]
fn sensor_data_metadata_and_refill() {
    let mount = Mounting {
        position_m: [3.7, 0.0, 0.5],
        orientation_rad: [0.0; 3],
    };
    let host = host_car([1.4, 0.0, 0.75], 0.0, [20.0, 0.0, 0.0]);
    let v = view(
        Some(host),
        vec![car(2, [40.0, 0.0, 0.75]), car(3, [60.0, 3.5, 0.75])],
        vec![],
        mount,
        12.34,
    );
    for kind in SensorKind::ALL {
        let mut s = IdealSensor::new(config(kind));
        let mut out = StepOutput::default();
        s.step(
            &StepInput {
                view: &v,
                time_s: 12.34,
                step_s: 0.05,
            },
            &mut out,
        )
        .unwrap();
        let first = out.clone();
        let sd = &first.sensor_data;
        assert_eq!(sd.version, Some(osiris_proto::interface_version()));
        assert_eq!(sd.timestamp, Some(timestamp_from_seconds(12.34)));
        assert_eq!(sd.sensor_id, Some(id(42)));
        assert_eq!(sd.mounting_position, Some(mount.to_osi()));
        assert_eq!(
            sd.moving_object_header.as_ref().unwrap().data_qualifier,
            Some(osi3::detected_entity_header::DataQualifier::Available as i32)
        );
        let fd = sd.feature_data.as_ref().unwrap();
        let header = match kind {
            SensorKind::Radar => fd.radar_sensor[0].header.as_ref(),
            SensorKind::Lidar => fd.lidar_sensor[0].header.as_ref(),
            SensorKind::Camera => fd.camera_sensor[0].header.as_ref(),
        }
        .unwrap();
        assert_eq!(header.mounting_position, Some(mount.to_osi()));
        assert_eq!(header.sensor_id, Some(id(42)));
        assert_eq!(header.measurement_time, Some(timestamp_from_seconds(12.34)));
        assert_eq!(
            fd.radar_sensor.len() + fd.lidar_sensor.len() + fd.camera_sensor.len(),
            1
        );
        let p = &first.perception;
        assert_eq!(
            (p.camera.is_some(), p.radar.is_some(), p.lidar.is_some()),
            (
                kind == SensorKind::Camera,
                kind == SensorKind::Radar,
                kind == SensorKind::Lidar
            )
        );
        assert_eq!(p.sensor_id, Some(id(42)));
        assert_eq!(moving_ids(&first), vec![2, 3]);
        // A second identical step refills the same content (only the cycle counter moves on).
        s.step(
            &StepInput {
                view: &v,
                time_s: 12.34,
                step_s: 0.05,
            },
            &mut out,
        )
        .unwrap();
        let mut again = out.clone();
        assert_eq!(again.perception.cycle_counter, Some(1));
        again.perception.cycle_counter = Some(0);
        let fd = again.sensor_data.feature_data.as_mut().unwrap();
        for h in fd.radar_sensor.iter_mut().filter_map(|x| x.header.as_mut()) {
            h.cycle_counter = Some(0);
        }
        for h in fd.lidar_sensor.iter_mut().filter_map(|x| x.header.as_mut()) {
            h.cycle_counter = Some(0);
        }
        for h in fd
            .camera_sensor
            .iter_mut()
            .filter_map(|x| x.header.as_mut())
        {
            h.cycle_counter = Some(0);
        }
        for h in [
            &mut again.sensor_data.moving_object_header,
            &mut again.sensor_data.stationary_object_header,
        ] {
            h.as_mut().unwrap().cycle_counter = Some(0);
        }
        // Ages advance only with time; the time did not change.
        assert_eq!(again.sensor_data, first.sensor_data);
        assert_eq!(again.perception, first.perception);
    }
}

#[test]
fn view_configuration_request_and_grant() {
    let mut s = IdealSensor::new(SensorConfig::default_for(SensorKind::Radar));
    let req = s.view_configuration_request();
    assert_eq!(req.version, Some(osiris_proto::interface_version()));
    assert_eq!(req.range, Some(100.0));
    assert_eq!(req.field_of_view_horizontal, Some(90f64.to_radians()));
    assert_eq!(req.update_cycle_time, Some(timestamp_from_seconds(0.05)));
    assert_eq!(req.radar_sensor_view_configuration.len(), 1);
    assert!(
        req.lidar_sensor_view_configuration.is_empty()
            && req.camera_sensor_view_configuration.is_empty()
    );
    assert_eq!(
        req.mounting_position,
        Some(
            SensorConfig::default_for(SensorKind::Radar)
                .mounting
                .to_osi()
        )
    );
    assert!(req.sensor_id.is_none());

    // An empty grant changes nothing and does not fail.
    assert!(
        s.apply_view_configuration(&osi3::SensorViewConfiguration::default())
            .unwrap()
            .is_empty()
    );
    // A smaller FoV and range (75 m of the default 100 m) are adopted with notes; a larger vertical
    // FoV is ignored.
    let granted = osi3::SensorViewConfiguration {
        sensor_id: Some(id(77)),
        field_of_view_horizontal: Some(1.0),
        field_of_view_vertical: Some(1.0),
        range: Some(75.0),
        radar_sensor_view_configuration: vec![osi3::RadarSensorViewConfiguration {
            field_of_view_horizontal: Some(0.8),
            ..Default::default()
        }],
        ..Default::default()
    };
    let notes = s.apply_view_configuration(&granted).unwrap();
    assert_eq!(notes.len(), 2, "{notes:?}");
    assert_eq!(s.config().fov_horizontal_rad, 0.8);
    assert_eq!(s.config().fov_vertical_rad, 10f64.to_radians());
    assert_eq!(s.config().range_m, 75.0);
    let req = s.view_configuration_request();
    assert_eq!(req.sensor_id, Some(id(77)));
    assert_eq!(
        req.radar_sensor_view_configuration[0].sensor_id,
        Some(id(77))
    );
    assert_eq!(req.field_of_view_horizontal, Some(0.8));
    // The learned id is used when a SensorView carries none.
    let mut v = view(
        None,
        vec![car(1, [30.0, 0.0, 0.0])],
        vec![],
        at_origin(),
        0.0,
    );
    v.sensor_id = None;
    let out = run(&mut s, &v);
    assert_eq!(out.sensor_data.sensor_id, Some(id(77)));
}

#[test]
fn orientation_is_relative_to_the_sensor() {
    let mut s = IdealSensor::new(config(SensorKind::Lidar));
    let target = vehicle(6, [20.0, -10.0, 0.0], 0.5, [4.5, 1.8, 1.5], [0.0; 3]);
    let mount = Mounting {
        position_m: [0.0; 3],
        orientation_rad: [0.0, 0.0, -0.2],
    };
    let out = run(&mut s, &view(None, vec![target], vec![], mount, 0.0));
    let o = out.sensor_data.moving_object[0]
        .base
        .as_ref()
        .unwrap()
        .orientation
        .unwrap();
    assert!((o.yaw.unwrap() - 0.7).abs() < 1e-12);
    // Object behind the spinning LiDAR is seen (2π FoV), not by a front camera.
    let behind = car(8, [-20.0, 0.0, 0.0]);
    let out = run(
        &mut s,
        &view(None, vec![behind.clone()], vec![], at_origin(), 0.0),
    );
    assert_eq!(moving_ids(&out), vec![8]);
    for det in &out.sensor_data.feature_data.as_ref().unwrap().lidar_sensor[0].detection {
        assert!(sph(&det.position).azimuth.abs() > PI - 0.1);
    }
}
