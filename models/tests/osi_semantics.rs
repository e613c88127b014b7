//! OSI 3.8.0 detection semantics of the models' SensorData (`osiris_models::semantics`):
//! detections refer to detected objects, stationary ground truth is reported as
//! `DetectedStationaryObject`, pedestrian candidates carry head and upper-body poses relative to
//! the host vehicle, camera boxes have 2 points, and the optional SensorView copy. The expected
//! poses and box corners are computed here from the scene, not by the library.

mod common;
use common::{dim, rpy, v3};
use std::f64::consts::PI;

use glam::{DMat3, DVec3};
use osiris_models::effects::EffectSwitches;
use osiris_models::frames::{Spherical, rotation_from_rpy};
use osiris_models::lidar::scan::{FlashPattern, ScanPattern};
use osiris_models::lidar::{LidarConfig, LidarSensor};
use osiris_models::semantics::violations;
use osiris_models::sensor::{ModelMode, Mounting};
use osiris_models::{SensorConfig, SensorKind, SensorModel, StepInput, StepOutput, build_sensor};
use osiris_proto::{id, osi3, timestamp_from_seconds};

use osi3::moving_object::pedestrian_attributes::bone::Type as Bone;
use osi3::stationary_object::classification::{Material, Type as SType};

fn moving(
    oid: u64,
    t: osi3::moving_object::Type,
    pos: DVec3,
    yaw: f64,
    size: [f64; 3],
    speed: f64,
) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(dim(size)),
            position: Some(v3(pos)),
            orientation: Some(rpy(0.0, 0.0, yaw)),
            velocity: Some(v3(speed * DVec3::new(yaw.cos(), yaw.sin(), 0.0))),
            orientation_rate: Some(rpy(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(t as i32),
        vehicle_classification: (t == osi3::moving_object::Type::Vehicle).then(|| {
            osi3::moving_object::VehicleClassification {
                r#type: Some(osi3::moving_object::vehicle_classification::Type::Car as i32),
                ..Default::default()
            }
        }),
        model_reference: Some(
            if t == osi3::moving_object::Type::Vehicle {
                "osiris:car"
            } else {
                "osiris:pedestrian"
            }
            .into(),
        ),
        ..Default::default()
    }
}

fn stationary(
    oid: u64,
    pos: DVec3,
    size: [f64; 3],
    t: SType,
    m: Material,
    model_reference: Option<String>,
) -> osi3::StationaryObject {
    osi3::StationaryObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(dim(size)),
            position: Some(v3(pos)),
            orientation: Some(rpy(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        classification: Some(osi3::stationary_object::Classification {
            r#type: Some(t as i32),
            material: Some(m as i32),
            ..Default::default()
        }),
        model_reference,
        ..Default::default()
    }
}

/// A skeleton whose head is yawed by `head_yaw` and upper spine by `spine_yaw` (root frame), the
/// other bones of the chain upright.
fn skeleton(head_yaw: f64, spine_yaw: f64) -> osi3::moving_object::PedestrianAttributes {
    let bone = |t: Bone, z: f64, yaw: f64| osi3::moving_object::pedestrian_attributes::Bone {
        r#type: Some(t as i32),
        position: Some(v3(DVec3::new(0.0, 0.0, z))),
        orientation: Some(rpy(0.0, 0.0, yaw)),
        ..Default::default()
    };
    osi3::moving_object::PedestrianAttributes {
        bbcenter_to_root: Some(v3(DVec3::new(0.0, 0.0, 0.05))),
        skeleton_bone: vec![
            bone(Bone::Root, 0.0, 0.0),
            bone(Bone::Hip, 0.0, 0.0),
            bone(Bone::LowerSpine, 0.1, 0.0),
            bone(Bone::UpperSpine, 0.3, spine_yaw),
            bone(Bone::Neck, 0.52, 0.0),
            bone(Bone::Head, 0.61, head_yaw),
        ],
    }
}

fn tracking_id(h: Option<&osi3::DetectedItemHeader>) -> u64 {
    h.unwrap().tracking_id.unwrap().value.unwrap()
}

fn gt_ids(h: Option<&osi3::DetectedItemHeader>) -> Vec<u64> {
    h.unwrap()
        .ground_truth_id
        .iter()
        .map(|i| i.value.unwrap())
        .collect()
}

/// Yaw difference wrapped into (−π, π].
fn dyaw(a: f64, b: f64) -> f64 {
    osiris_models::frames::wrap_angle(a - b)
}

// ------------------------------------------------------------------------------------------------
// Ideal model

const HOST_YAW: f64 = 10.0 * PI / 180.0;
const MOUNT_YAW: f64 = 5.0 * PI / 180.0;

/// Host-frame position → global (the host's box centre at z = 0.75, yawed by `HOST_YAW`).
fn at_host(x: f64, y: f64, z: f64) -> DVec3 {
    DMat3::from_rotation_z(HOST_YAW) * DVec3::new(x, y, z - 0.75) + DVec3::new(0.0, 0.0, 0.75)
}

struct IdealScene {
    view: osi3::SensorView,
    sensor_pos: DVec3,
    sensor_rot: DMat3,
}

fn ideal_scene() -> IdealScene {
    use osi3::moving_object::Type;
    let host = moving(
        1,
        Type::Vehicle,
        at_host(0.0, 0.0, 0.75),
        HOST_YAW,
        [4.5, 1.8, 1.5],
        0.0,
    );
    let car = moving(
        100,
        Type::Vehicle,
        at_host(25.0, 2.0, 0.75),
        HOST_YAW,
        [4.5, 1.8, 1.5],
        8.0,
    );
    // A standing pedestrian with a skeleton, facing 30° (global), and a walking one without.
    let mut ped = moving(
        5,
        Type::Pedestrian,
        at_host(15.0, -3.0, 0.9),
        30f64.to_radians(),
        [0.5, 0.6, 1.8],
        0.0,
    );
    ped.pedestrian_attributes = Some(skeleton(20f64.to_radians(), -10f64.to_radians()));
    let walker = moving(
        6,
        Type::Pedestrian,
        at_host(18.0, 4.0, 0.9),
        -40f64.to_radians(),
        [0.5, 0.6, 1.8],
        1.2,
    );
    let wall = stationary(
        20,
        at_host(30.0, -6.0, 1.0),
        [0.5, 3.0, 2.0],
        SType::Wall,
        Material::Concrete,
        None,
    );
    let cone = stationary(
        21,
        at_host(12.0, 3.0, 0.35),
        [0.4, 0.4, 0.7],
        SType::Pylon,
        Material::Plastic,
        None,
    );
    let mounting = Mounting {
        position_m: [2.0, 0.0, 1.0],
        orientation_rad: [0.0, 0.0, MOUNT_YAW],
    };
    let view = osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(timestamp_from_seconds(0.0)),
        sensor_id: Some(id(42)),
        mounting_position: Some(mounting.to_osi()),
        host_vehicle_id: Some(id(1)),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(timestamp_from_seconds(0.0)),
            host_vehicle_id: Some(id(1)),
            moving_object: vec![host, car, ped, walker],
            stationary_object: vec![wall, cone],
            ..Default::default()
        }),
        ..Default::default()
    };
    IdealScene {
        view,
        sensor_pos: at_host(2.0, 0.0, 1.75),
        sensor_rot: DMat3::from_rotation_z(HOST_YAW + MOUNT_YAW),
    }
}

fn ideal_config(kind: SensorKind) -> SensorConfig {
    let mut c = SensorConfig::default_for(kind);
    c.mode = ModelMode::Ideal;
    c.fov_vertical_rad = 40f64.to_radians();
    c
}

fn step(model: &mut dyn SensorModel, view: &osi3::SensorView, t: f64) -> StepOutput {
    let mut out = StepOutput::default();
    model
        .step(
            &StepInput {
                view,
                time_s: t,
                step_s: 0.1,
            },
            &mut out,
        )
        .expect("step");
    out
}

/// Every kind of the ideal model: the rules hold, stationary ground truth is stationary, a
/// standing pedestrian is a moving object, the pedestrians' poses are relative to the host
/// (independent of the sensor's 5° mounting yaw): from the skeleton (head 30° + 20° − 10° = 40°,
/// upper body 30° − 10° − 10° = 10°) or, without one, the body (−40° − 10° = −50°).
#[test]
fn ideal_model_follows_the_osi_detection_semantics() {
    let scene = ideal_scene();
    let gt = scene.view.global_ground_truth.as_ref().unwrap();
    for kind in SensorKind::ALL {
        let mut m = build_sensor(ideal_config(kind)).unwrap();
        let out = step(m.as_mut(), &scene.view, 0.0);
        let sd = &out.sensor_data;
        assert_eq!(violations(sd, Some(gt)), Vec::<String>::new(), "{kind:?}");
        let mut stationary: Vec<u64> = sd
            .stationary_object
            .iter()
            .flat_map(|s| gt_ids(s.header.as_ref()))
            .collect();
        stationary.sort();
        assert_eq!(stationary, vec![20, 21], "{kind:?}");
        let cone = sd
            .stationary_object
            .iter()
            .find(|s| gt_ids(s.header.as_ref()) == [21])
            .unwrap();
        let cls = cone.candidate[0].classification.as_ref().unwrap();
        assert_eq!(
            (cls.r#type, cls.material),
            (Some(SType::Pylon as i32), Some(Material::Plastic as i32))
        );
        let mut moving: Vec<u64> = sd
            .moving_object
            .iter()
            .flat_map(|s| gt_ids(s.header.as_ref()))
            .collect();
        moving.sort();
        assert_eq!(moving, vec![5, 6, 100], "{kind:?}");
        let obj = |g: u64| {
            sd.moving_object
                .iter()
                .find(|o| gt_ids(o.header.as_ref()) == [g])
                .unwrap()
        };
        assert_eq!(
            obj(5).movement_state,
            Some(osi3::detected_moving_object::MovementState::Stationary as i32)
        );
        let poses = |g: u64| {
            let c = &obj(g).candidate[0];
            let (h, u) = (c.head_pose.unwrap(), c.upper_body_pose.unwrap());
            for o in [h, u] {
                assert!(o.roll.unwrap().abs() < 1e-9 && o.pitch.unwrap().abs() < 1e-9);
            }
            (h.yaw.unwrap(), u.yaw.unwrap())
        };
        let (h, u) = poses(5);
        assert!(
            dyaw(h, 40f64.to_radians()).abs() < 1e-3,
            "{kind:?}: head {}",
            h.to_degrees()
        );
        assert!(
            dyaw(u, 10f64.to_radians()).abs() < 1e-3,
            "{kind:?}: upper {}",
            u.to_degrees()
        );
        let (h, u) = poses(6);
        assert!(
            dyaw(h, -50f64.to_radians()).abs() < 1e-9,
            "{kind:?}: {}",
            h.to_degrees()
        );
        assert!(dyaw(u, -50f64.to_radians()).abs() < 1e-9);
        // A vehicle candidate has no poses.
        assert!(obj(100).candidate[0].head_pose.is_none());
        // Every detection names a reported object (ideal: tracking id = ground-truth id).
        let fd = sd.feature_data.as_ref().unwrap();
        let n = fd
            .radar_sensor
            .iter()
            .map(|r| r.detection.len())
            .sum::<usize>()
            + fd.lidar_sensor
                .iter()
                .map(|r| r.detection.len())
                .sum::<usize>()
            + fd.camera_sensor
                .iter()
                .map(|r| r.detection.len())
                .sum::<usize>();
        assert!(n >= 5, "{kind:?}: {n} detections");
    }
}

/// The ideal camera's 2-point box is the azimuth–elevation extent of the object's 8 box corners
/// (computed here from the ground truth and the sensor pose), at the box's nearest range.
#[test]
fn ideal_camera_boxes_are_two_corner_points() {
    let scene = ideal_scene();
    let gt = scene.view.global_ground_truth.as_ref().unwrap();
    let mut m = build_sensor(ideal_config(SensorKind::Camera)).unwrap();
    let out = step(m.as_mut(), &scene.view, 0.0);
    let cam = &out.sensor_data.feature_data.as_ref().unwrap().camera_sensor[0];
    assert_eq!(cam.detection.len(), 5);
    assert_eq!(cam.point.len(), 10);
    for d in &cam.detection {
        assert_eq!(d.number_of_points, Some(2));
        let g = d.object_id.unwrap().value.unwrap();
        let (pos, yaw, size) = gt
            .moving_object
            .iter()
            .map(|o| (o.id, o.base.as_ref().unwrap()))
            .map(|(i, b)| {
                (
                    i,
                    b.position.unwrap(),
                    b.orientation.unwrap().yaw,
                    b.dimension.unwrap(),
                )
            })
            .chain(gt.stationary_object.iter().map(|o| {
                let b = o.base.as_ref().unwrap();
                (
                    o.id,
                    b.position.unwrap(),
                    b.orientation.unwrap().yaw,
                    b.dimension.unwrap(),
                )
            }))
            .find(|x| x.0.unwrap().value == Some(g))
            .map(|(_, p, y, s)| {
                (
                    DVec3::new(p.x.unwrap(), p.y.unwrap(), p.z.unwrap()),
                    y.unwrap(),
                    DVec3::new(s.length.unwrap(), s.width.unwrap(), s.height.unwrap()) / 2.0,
                )
            })
            .unwrap();
        let mut az = Vec::new();
        let mut el = Vec::new();
        let mut dist = Vec::new();
        for k in 0..8 {
            let s = |b: usize| if k & b != 0 { 1.0 } else { -1.0 };
            let c = pos + rotation_from_rpy(0.0, 0.0, yaw) * (size * DVec3::new(s(4), s(2), s(1)));
            let q = scene.sensor_rot.transpose() * (c - scene.sensor_pos);
            let sph = Spherical::from_cartesian(q);
            az.push(sph.azimuth);
            el.push(sph.elevation);
            dist.push(sph.distance);
        }
        let max = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let first = d.first_point_index.unwrap() as usize;
        let p0 = Spherical::from_osi(cam.point[first].point.as_ref().unwrap());
        let p1 = Spherical::from_osi(cam.point[first + 1].point.as_ref().unwrap());
        assert!((p0.azimuth - max(&az)).abs() < 1e-9, "{g}: {p0:?} {az:?}");
        assert!((p0.elevation - max(&el)).abs() < 1e-9, "{g}");
        assert!((p1.azimuth - min(&az)).abs() < 1e-9, "{g}");
        assert!((p1.elevation - min(&el)).abs() < 1e-9, "{g}");
        // The nearest point of the box is nearer than any corner, and the box centre's range
        // minus its half diagonal bounds it from below.
        let centre = (scene.sensor_rot.transpose() * (pos - scene.sensor_pos)).length();
        assert!(p0.distance <= min(&dist) + 1e-9 && p0.distance >= centre - size.length() - 1e-9);
        assert_eq!(p0.distance, p1.distance);
    }
}

/// `include_sensor_view`: off by default (no copy); on, SensorData.sensor_view is the input.
#[test]
fn sensor_view_copy_is_opt_in() {
    let scene = ideal_scene();
    let mut c = ideal_config(SensorKind::Radar);
    let mut m = build_sensor(c.clone()).unwrap();
    assert!(
        step(m.as_mut(), &scene.view, 0.0)
            .sensor_data
            .sensor_view
            .is_empty()
    );
    assert!(
        !serde_json::to_string(&c)
            .unwrap()
            .contains("include_sensor_view")
    );
    c.include_sensor_view = true;
    let json = serde_json::to_string(&c).unwrap();
    assert!(json.contains("\"include_sensor_view\":true"), "{json}");
    let parsed = SensorConfig::from_json_str(&json).unwrap();
    assert!(parsed.include_sensor_view);
    let mut m = build_sensor(parsed).unwrap();
    for k in 0..2 {
        let out = step(m.as_mut(), &scene.view, 0.1 * k as f64);
        assert_eq!(out.sensor_data.sensor_view, vec![scene.view.clone()]);
        assert!(!out.sensor_data.moving_object.is_empty());
    }
}

// ------------------------------------------------------------------------------------------------
// Physical LiDAR

fn lidar_view(t: f64) -> osi3::SensorView {
    use osi3::moving_object::Type;
    // A 1 m × 1 m board (stationary, wood) 15 m ahead on the left, a parked car (a moving object
    // at rest) 20 m ahead on the right.
    let board = stationary(
        30,
        DVec3::new(15.0, 2.0, 1.0),
        [0.01, 1.0, 1.0],
        SType::RectangularStructure,
        Material::Wood,
        Some(
            "osiris:board?width_m=1&height_m=1&thickness_m=0&mount=none&material=lambertian_50"
                .into(),
        ),
    );
    let car = moving(
        31,
        Type::Vehicle,
        DVec3::new(20.0, -3.0, 0.75),
        0.0,
        [4.5, 1.8, 1.5],
        0.0,
    );
    osi3::SensorView {
        timestamp: Some(timestamp_from_seconds(t)),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(timestamp_from_seconds(t)),
            stationary_object: vec![board],
            moving_object: vec![car],
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn lidar_config() -> SensorConfig {
    let effects: EffectSwitches = [
        ("lidar.detector_noise", false),
        ("lidar.solar_background", false),
        ("lidar.dropped_rays", false),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v))
    .collect();
    let mut c = SensorConfig::default_for(SensorKind::Lidar);
    c.mode = ModelMode::Physical;
    c.mounting = Mounting {
        position_m: [0.0, 0.0, 1.0],
        orientation_rad: [0.0; 3],
    };
    c.effects = effects;
    c.seed = Some(3);
    c.lidar = Some(LidarConfig {
        scan: Some(ScanPattern::Flash(FlashPattern {
            rows: 48,
            cols: 240,
            fov_horizontal_rad: 60f64.to_radians(),
            fov_vertical_rad: 24f64.to_radians(),
            centre_rad: [0.0, -4f64.to_radians()],
        })),
        ..Default::default()
    });
    c
}

/// The physical LiDAR: points refer to the tracked object of their cluster once it is confirmed
/// (none before), the board's track is a `DetectedStationaryObject` with the ground truth's
/// classification, the parked car stays a moving object.
#[test]
fn physical_lidar_reports_stationary_ground_truth_as_stationary_objects() {
    let mut s = LidarSensor::new(lidar_config()).unwrap();
    let mut out = StepOutput::default();
    for k in 0..5 {
        let t = 0.1 * k as f64;
        let v = lidar_view(t);
        s.step(
            &StepInput {
                view: &v,
                time_s: t,
                step_s: 0.1,
            },
            &mut out,
        )
        .unwrap();
        let sd = &out.sensor_data;
        let gt = v.global_ground_truth.as_ref().unwrap();
        assert_eq!(violations(sd, Some(gt)), Vec::<String>::new(), "cycle {k}");
        let dets = &sd.feature_data.as_ref().unwrap().lidar_sensor[0].detection;
        let truth = &out.perception.lidar.as_ref().unwrap().object_id;
        assert_eq!(dets.len(), truth.len());
        let on = |g: u64| (0..dets.len()).filter(move |&i| truth[i] == g);
        assert!(on(30).count() >= 20 && on(31).count() >= 50, "cycle {k}");
        if k < 2 {
            assert!(sd.moving_object.is_empty() && sd.stationary_object.is_empty());
            assert!(dets.iter().all(|d| d.object_id.is_none()), "cycle {k}");
            continue;
        }
        let board = sd
            .stationary_object
            .iter()
            .find(|o| gt_ids(o.header.as_ref()) == [30])
            .unwrap_or_else(|| panic!("cycle {k}: no stationary board: {sd:#?}"));
        let cls = board.candidate[0].classification.as_ref().unwrap();
        assert_eq!(
            (cls.r#type, cls.material, board.candidate[0].probability),
            (
                Some(SType::RectangularStructure as i32),
                Some(Material::Wood as i32),
                Some(1.0)
            )
        );
        let p = board.base.as_ref().unwrap().position.unwrap();
        let p = DVec3::new(p.x.unwrap(), p.y.unwrap(), p.z.unwrap());
        assert!(
            (p - DVec3::new(15.0, 2.0, 0.0)).truncate().length() < 0.5,
            "{p:?}"
        );
        let car = sd
            .moving_object
            .iter()
            .find(|o| gt_ids(o.header.as_ref()) == [31])
            .unwrap_or_else(|| panic!("cycle {k}: the parked car is not a moving object"));
        assert!(
            sd.moving_object
                .iter()
                .all(|o| !gt_ids(o.header.as_ref()).contains(&30))
        );
        let (tb, tc) = (
            tracking_id(board.header.as_ref()),
            tracking_id(car.header.as_ref()),
        );
        assert_ne!(tb, tc);
        // Every board point is the board's; the car's points above the ground segmentation's
        // band are the car's.
        assert!(
            on(30).all(|i| dets[i].object_id == Some(id(tb))),
            "cycle {k}"
        );
        let car_pts: Vec<usize> = on(31).collect();
        let n = car_pts
            .iter()
            .filter(|&&i| dets[i].object_id == Some(id(tc)))
            .count();
        assert!(
            n * 10 >= car_pts.len() * 8,
            "cycle {k}: {n} of {}",
            car_pts.len()
        );
    }
}
