//! Recognition tests: LiDAR boxes from ray-cast synthetic scans, radar clustering, ego-motion
//! compensation, ghost rejection and tracking against closed-form expectations.

use glam::{DMat3, DVec2, DVec3};
use osiris_models::frames::Pose;
use osiris_models::recognition::lidar::{LidarRecognition, LidarRecognitionConfig, fit_ground};
use osiris_models::recognition::radar::{
    RadarRecognition, RadarRecognitionConfig, compensated_range_rate,
};
use osiris_models::recognition::{EgoState, LidarPoint, RadarDetection};
use osiris_models::sensor::ModelError;
use osiris_proto::osi3;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

// ------------------------------------------------------------------------------------------------
// Helpers

fn ego(time_s: f64, position: DVec3, yaw: f64, velocity: DVec3) -> EgoState {
    EgoState {
        time_s,
        sensor_pose: Pose::new(position, DMat3::from_rotation_z(yaw)),
        sensor_velocity_m_s: velocity,
        sensor_angular_velocity_rad_s: DVec3::ZERO,
    }
}

/// An oriented box standing on the ground (fixed frame).
#[derive(Clone, Copy)]
struct Boxx {
    centre: DVec3,
    yaw: f64,
    half: DVec3,
    id: u64,
}

impl Boxx {
    fn on_ground(ground_z: f64, xy: DVec2, yaw: f64, size: [f64; 3], id: u64) -> Boxx {
        Boxx {
            centre: DVec3::new(xy.x, xy.y, ground_z + size[2] / 2.0),
            yaw,
            half: DVec3::new(size[0], size[1], size[2]) / 2.0,
            id,
        }
    }

    /// Slab-test ray intersection distance.
    fn hit(&self, o: DVec3, d: DVec3) -> Option<f64> {
        let r = DMat3::from_rotation_z(self.yaw).transpose();
        let ol = r * (o - self.centre);
        let dl = r * d;
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            let (oa, da, h) = (ol[a], dl[a], self.half[a]);
            if da.abs() < 1e-15 {
                if oa.abs() > h {
                    return None;
                }
            } else {
                let (mut ta, mut tb) = ((-h - oa) / da, (h - oa) / da);
                if ta > tb {
                    std::mem::swap(&mut ta, &mut tb);
                }
                t0 = t0.max(ta);
                t1 = t1.min(tb);
                if t0 > t1 {
                    return None;
                }
            }
        }
        (t0 > 0.0).then_some(t0)
    }
}

/// A 128-channel spinning LiDAR scan (vertical −25°…+15°, 0.2° azimuth steps over ±60°) of a
/// ground `z = g(x, y)` (linear: `z = c + a·x + b·y`) and boxes, from a sensor at `sensor_pos`
/// with yaw 0. Points in the sensor frame with 2 cm Gaussian range noise.
fn lidar_scan(sensor_pos: DVec3, ground: [f64; 3], boxes: &[Boxx], seed: u64) -> Vec<LidarPoint> {
    let [c, a, b] = ground;
    let n = DVec3::new(-a, -b, 1.0);
    let mut rng = SmallRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.02).unwrap();
    let mut pts = Vec::new();
    for ch in 0..128 {
        let el = (-25.0 + 40.0 * ch as f64 / 127.0).to_radians();
        for k in 0..=600 {
            let az = (-60.0 + 0.2 * k as f64).to_radians();
            let d = DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
            // Ground: n·(o + t d) = c  (n·p = c with n = (−a, −b, 1)).
            let mut best: Option<(f64, u64)> = None;
            let den = n.dot(d);
            if den.abs() > 1e-12 {
                let t = (c - n.dot(sensor_pos)) / den;
                if t > 0.0 && t < 120.0 {
                    best = Some((t, osiris_proto::INVALID_ID));
                }
            }
            for bx in boxes {
                if let Some(t) = bx.hit(sensor_pos, d)
                    && best.is_none_or(|(bt, _)| t < bt)
                {
                    best = Some((t, bx.id));
                }
            }
            if let Some((t, id)) = best {
                let t = t + noise.sample(&mut rng);
                pts.push(LidarPoint {
                    position_m: d * t,
                    intensity: 50.0,
                    range_rate_m_s: None,
                    object_id: id,
                });
            }
        }
    }
    pts
}

fn pos_of(o: &osi3::DetectedMovingObject) -> DVec3 {
    let p = o.base.as_ref().unwrap().position.unwrap();
    DVec3::new(p.x.unwrap(), p.y.unwrap(), p.z.unwrap())
}

/// Where a radar object's reported box centre belongs (fixed frame) when its reflection centroid
/// is at `p`: the reported box (its `dimension`) placed behind the face the sensor at `s` sees,
/// heading `h` (fixed frame, the target's velocity): `p + u·((L/2)|u·h| + (W/2)|u×h|)`, u the
/// horizontal line of sight.
fn box_centre_behind(o: &osi3::DetectedMovingObject, s: DVec3, p: DVec3, h: DVec3) -> DVec3 {
    let d = o.base.as_ref().unwrap().dimension.unwrap();
    let (l, w) = (d.length.unwrap(), d.width.unwrap());
    let u = DVec3::new(p.x - s.x, p.y - s.y, 0.0).normalize();
    let h = DVec3::new(h.x, h.y, 0.0).normalize();
    let depth = 0.5 * l * u.dot(h).abs() + 0.5 * w * (u.x * h.y - u.y * h.x).abs();
    p + u * depth
}

fn vel_of(o: &osi3::DetectedMovingObject) -> DVec3 {
    let p = o.base.as_ref().unwrap().velocity.unwrap();
    DVec3::new(p.x.unwrap(), p.y.unwrap(), p.z.unwrap())
}

fn yaw_of(o: &osi3::DetectedMovingObject) -> f64 {
    o.base.as_ref().unwrap().orientation.unwrap().yaw.unwrap()
}

/// Difference of two axis angles modulo π, rad in [0, π/2].
fn axis_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::PI);
    d.min(std::f64::consts::PI - d)
}

fn top_type(o: &osi3::DetectedMovingObject) -> (i32, Option<i32>) {
    let c = &o.candidate[0];
    (
        c.r#type.unwrap(),
        c.vehicle_classification.as_ref().and_then(|v| v.r#type),
    )
}

const CAR: [f64; 3] = [4.5, 1.8, 1.5];
const SENSOR_HEIGHT_M: f64 = 1.8;

/// Runs `steps` static scans through a fresh recognition; returns the last output.
fn run_lidar(boxes: &[Boxx], ground: [f64; 3], steps: usize) -> Vec<osi3::DetectedMovingObject> {
    let mut rec = LidarRecognition::new(&LidarRecognitionConfig::default()).unwrap();
    let sensor = DVec3::new(0.0, 0.0, SENSOR_HEIGHT_M);
    let mut out = Vec::new();
    for s in 0..steps {
        out.clear();
        let pts = lidar_scan(sensor, ground, boxes, s as u64);
        rec.step(
            &ego(0.1 * s as f64, sensor, 0.0, DVec3::ZERO),
            &pts,
            &mut out,
        );
    }
    out
}

// ------------------------------------------------------------------------------------------------
// LiDAR

#[test]
fn lidar_car_boxes_within_0_3_m_of_ground_truth() {
    let sensor = DVec3::new(0.0, 0.0, SENSOR_HEIGHT_M);
    let mut worst_pos: f64 = 0.0;
    let mut worst_yaw: f64 = 0.0;
    for &dist in &[10.0, 20.0, 30.0] {
        for &(lateral, yaw_deg) in &[
            (0.0, 0.0),
            (0.0, 180.0),
            (3.5, 0.0),
            (-3.5, 30.0),
            (4.0, 90.0),
            (-2.0, -45.0),
        ] {
            let yaw = f64::to_radians(yaw_deg);
            let car = Boxx::on_ground(0.0, DVec2::new(dist, lateral), yaw, CAR, 7);
            let out = run_lidar(&[car], [0.0, 0.0, 0.0], 5);
            assert_eq!(
                out.len(),
                1,
                "d={dist} lat={lateral} yaw={yaw_deg}: {out:?}"
            );
            let o = &out[0];
            let expect = car.centre - sensor;
            let err = (pos_of(o) - expect).truncate().length();
            let yerr = axis_diff(yaw_of(o), yaw);
            worst_pos = worst_pos.max(err);
            worst_yaw = worst_yaw.max(yerr);
            assert!(
                err < 0.3,
                "d={dist} lat={lateral} yaw={yaw_deg}: centre {:?} vs {expect:?} ({err:.3} m)",
                pos_of(o)
            );
            assert!(
                (pos_of(o).z - expect.z).abs() < 0.15,
                "height centre {:?}",
                pos_of(o)
            );
            assert!(
                yerr < 3f64.to_radians(),
                "d={dist} lat={lateral} yaw={yaw_deg}: yaw {:.2}°",
                yaw_of(o).to_degrees()
            );
            assert_eq!(
                top_type(o),
                (
                    osi3::moving_object::Type::Vehicle as i32,
                    Some(osi3::moving_object::vehicle_classification::Type::Car as i32)
                )
            );
            let h = o.header.as_ref().unwrap();
            assert_eq!(h.ground_truth_id[0].value, Some(7));
            let dim = o.base.as_ref().unwrap().dimension.unwrap();
            assert!((dim.height.unwrap() - 1.5).abs() < 0.1, "{dim:?}");
        }
    }
    eprintln!(
        "worst centre error {worst_pos:.3} m, worst yaw error {:.2}°",
        worst_yaw.to_degrees()
    );
}

#[test]
fn lidar_ground_removed_on_tilted_plane() {
    // Ground rising 4° along x and 2° along y, passing 1.8 m below the sensor.
    let (a, b) = (4f64.to_radians().tan(), 2f64.to_radians().tan());
    let sensor = DVec3::new(0.0, 0.0, SENSOR_HEIGHT_M);
    let pts = lidar_scan(sensor, [0.0, a, b], &[], 1);
    let fixed: Vec<DVec3> = pts.iter().map(|p| p.position_m + sensor).collect();
    let g = fit_ground(&fixed, 0.15, 0.2, 100, 1).expect("plane");
    let truth = DVec3::new(-a, -b, 1.0).normalize();
    let angle = g.normal.angle_between(truth);
    assert!(angle < 0.3f64.to_radians(), "normal off by {angle} rad");
    assert!(g.height_of(DVec3::ZERO).abs() < 0.05, "offset {}", g.d);
    // Only ground: no object at all.
    let out = run_lidar(&[], [0.0, a, b], 5);
    assert!(out.is_empty(), "{out:?}");
    // A car standing on the slope is still found (centre within 0.3 m).
    let xy = DVec2::new(18.0, 2.0);
    let gz = a * xy.x + b * xy.y;
    let car = Boxx::on_ground(gz, xy, 0.3, CAR, 3);
    let out = run_lidar(&[car], [0.0, a, b], 5);
    assert_eq!(out.len(), 1);
    let err = (pos_of(&out[0]) - (car.centre - sensor))
        .truncate()
        .length();
    assert!(err < 0.3, "{err}");
}

#[test]
fn lidar_two_nearby_cars_are_separated() {
    // Two cars side by side with a 1.2 m gap, 15 m ahead.
    let a = Boxx::on_ground(0.0, DVec2::new(15.0, 1.5), 0.0, CAR, 1);
    let b = Boxx::on_ground(0.0, DVec2::new(15.0, -1.5), 0.0, CAR, 2);
    let out = run_lidar(&[a, b], [0.0, 0.0, 0.0], 5);
    assert_eq!(out.len(), 2, "{out:?}");
    let sensor = DVec3::new(0.0, 0.0, SENSOR_HEIGHT_M);
    for car in [a, b] {
        let o = out
            .iter()
            .find(|o| o.header.as_ref().unwrap().ground_truth_id[0].value == Some(car.id))
            .unwrap();
        let err = (pos_of(o) - (car.centre - sensor)).truncate().length();
        assert!(err < 0.3, "car {}: {err}", car.id);
    }
    let ids: Vec<_> = out
        .iter()
        .map(|o| o.header.as_ref().unwrap().tracking_id.unwrap().value)
        .collect();
    assert_ne!(ids[0], ids[1]);
}

#[test]
fn lidar_classifies_car_and_pedestrian_by_size() {
    let car = Boxx::on_ground(0.0, DVec2::new(14.0, 4.0), 0.2, CAR, 1);
    let ped = Boxx::on_ground(0.0, DVec2::new(12.0, -3.0), 0.0, [0.5, 0.5, 1.75], 2);
    let out = run_lidar(&[car, ped], [0.0, 0.0, 0.0], 5);
    assert_eq!(out.len(), 2);
    for o in &out {
        let gid = o.header.as_ref().unwrap().ground_truth_id[0].value.unwrap();
        let (t, v) = top_type(o);
        if gid == 1 {
            assert_eq!(t, osi3::moving_object::Type::Vehicle as i32);
            assert_eq!(
                v,
                Some(osi3::moving_object::vehicle_classification::Type::Car as i32)
            );
        } else {
            assert_eq!(t, osi3::moving_object::Type::Pedestrian as i32);
            // A pedestrian box is not extended to a vehicle's size.
            let d = o.base.as_ref().unwrap().dimension.unwrap();
            assert!(d.length.unwrap() < 0.8 && d.width.unwrap() < 0.8, "{d:?}");
        }
        let p = o.candidate[0].probability.unwrap();
        assert!(p > 0.5 && p <= 1.0, "{p}");
    }
}

#[test]
fn lidar_moving_car_velocity_and_heading() {
    // Car driving at 8 m/s along +y·sin + x·cos (heading 20°), sensor moving at 5 m/s along +x.
    let mut rec = LidarRecognition::new(&LidarRecognitionConfig::default()).unwrap();
    let heading = 20f64.to_radians();
    let v_car = DVec3::new(heading.cos(), heading.sin(), 0.0) * 8.0;
    let v_s = DVec3::new(5.0, 0.0, 0.0);
    let mut out = Vec::new();
    let dt = 0.1;
    for s in 0..20 {
        let t = dt * s as f64;
        let sensor = DVec3::new(0.0, 0.0, SENSOR_HEIGHT_M) + v_s * t;
        let xy = DVec2::new(15.0, -2.0) + v_car.truncate() * t;
        let car = Boxx::on_ground(0.0, xy, heading, CAR, 9);
        let pts = lidar_scan(sensor, [0.0, 0.0, 0.0], &[car], s);
        out.clear();
        rec.step(&ego(t, sensor, 0.0, v_s), &pts, &mut out);
    }
    assert_eq!(out.len(), 1);
    let rel = vel_of(&out[0]);
    let expect = v_car - v_s;
    assert!(
        (rel - expect).truncate().length() < 0.5,
        "{rel:?} vs {expect:?}"
    );
    // Heading points along the velocity (not flipped by π).
    let yaw = yaw_of(&out[0]);
    assert!(
        osiris_models::frames::wrap_angle(yaw - heading).abs() < 3f64.to_radians(),
        "{yaw}"
    );
    assert_eq!(
        out[0].movement_state,
        Some(osi3::detected_moving_object::MovementState::Moving as i32)
    );
}

#[test]
fn lidar_output_in_sensor_frame_with_rotated_pose() {
    // The same scan, but the sensor is yawed by 130° and placed at (50, −20) in the fixed frame:
    // the reported box (sensor frame) must not change.
    let car = Boxx::on_ground(0.0, DVec2::new(16.0, 3.0), 0.4, CAR, 4);
    let sensor_local = DVec3::new(0.0, 0.0, SENSOR_HEIGHT_M);
    let yaw = 130f64.to_radians();
    let pos = DVec3::new(50.0, -20.0, SENSOR_HEIGHT_M);
    let mut rec = LidarRecognition::new(&LidarRecognitionConfig::default()).unwrap();
    let mut out = Vec::new();
    for s in 0..5 {
        let pts = lidar_scan(sensor_local, [0.0, 0.0, 0.0], &[car], s);
        out.clear();
        rec.step(&ego(0.1 * s as f64, pos, yaw, DVec3::ZERO), &pts, &mut out);
    }
    assert_eq!(out.len(), 1);
    let err = (pos_of(&out[0]) - (car.centre - sensor_local))
        .truncate()
        .length();
    assert!(err < 0.3, "{err}");
    assert!(axis_diff(yaw_of(&out[0]), 0.4) < 3f64.to_radians());
}

#[test]
fn lidar_config_errors_name_the_key() {
    let c = LidarRecognitionConfig {
        cluster_tolerance_m: -1.0,
        ..Default::default()
    };
    match LidarRecognition::new(&c) {
        Err(ModelError::Config(m)) => assert!(m.contains("cluster_tolerance_m"), "{m}"),
        other => panic!("{other:?}"),
    }
    let mut c = LidarRecognitionConfig::default();
    c.tracker.confirm_m = 9;
    match LidarRecognition::new(&c) {
        Err(ModelError::Config(m)) => assert!(m.contains("tracker.confirm_m"), "{m}"),
        other => panic!("{other:?}"),
    }
    let parsed: Result<LidarRecognitionConfig, _> =
        serde_json::from_str(r#"{"cluster_tolerance": 0.5}"#);
    assert!(parsed.is_err());
    let parsed: LidarRecognitionConfig =
        serde_json::from_str(r#"{"cluster_tolerance_m": 0.4, "tracker": {"confirm_m": 2}}"#)
            .unwrap();
    assert_eq!(parsed.cluster_tolerance_m, 0.4);
    assert_eq!(parsed.tracker.confirm_m, 2);
    assert_eq!(parsed.tracker.confirm_n, 5);
}

// ------------------------------------------------------------------------------------------------
// Radar

/// A noiseless radar detection of a point `p` (fixed frame) moving with `v`, as seen by `e`.
fn detection_of(e: &EgoState, p: DVec3, v: DVec3, rcs: f64, id: u64) -> RadarDetection {
    let ps = e.sensor_pose.inverse_transform_point(p);
    let r = ps.length();
    let rel = p - e.sensor_pose.position;
    RadarDetection {
        range_m: r,
        azimuth_rad: ps.y.atan2(ps.x),
        elevation_rad: (ps.z / r).asin(),
        range_rate_m_s: rel.dot(v - e.sensor_velocity_m_s) / rel.length(),
        snr_db: 20.0,
        rcs_dbsm: rcs,
        object_id: id,
    }
}

#[test]
fn radar_ego_motion_compensation_of_stationary_clutter() {
    // Sensor yawed 30° in the fixed frame, moving at 20 m/s along its heading plus 1 m/s sideways.
    let yaw = 30f64.to_radians();
    let v = DMat3::from_rotation_z(yaw) * DVec3::new(20.0, 1.0, 0.0);
    let e = ego(0.0, DVec3::new(5.0, -3.0, 0.5), yaw, v);
    for az_deg in [-75.0, -45.0, -10.0, 0.0, 20.0, 60.0, 80.0] {
        for el_deg in [-3.0, 0.0, 4.0] {
            let (az, el) = (f64::to_radians(az_deg), f64::to_radians(el_deg));
            let u_s = DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
            // Closed form: a stationary target has ṙ = −v_s·u (sensor-frame velocity (20, 1, 0)).
            let rr = -(20.0 * u_s.x + 1.0 * u_s.y);
            let d = RadarDetection {
                range_m: 30.0,
                azimuth_rad: az,
                elevation_rad: el,
                range_rate_m_s: rr,
                snr_db: 20.0,
                rcs_dbsm: 0.0,
                object_id: osiris_proto::INVALID_ID,
            };
            assert!(compensated_range_rate(&e, &d).abs() < 1e-9);
            // A target moving at w (fixed frame): compensated = w · u (fixed-frame u).
            let w = DVec3::new(-3.0, 4.0, 0.0);
            let u = e.sensor_pose.transform_vector(u_s);
            let d2 = RadarDetection {
                range_rate_m_s: (w - v).dot(u),
                ..d
            };
            assert!((compensated_range_rate(&e, &d2) - w.dot(u)).abs() < 1e-9);
        }
    }
    // Through the whole recognition: stationary clutter is classified stationary and never tracked.
    let mut rec = RadarRecognition::new(&RadarRecognitionConfig::default()).unwrap();
    let mut out = Vec::new();
    for s in 0..10 {
        let t = 0.05 * s as f64;
        let e = ego(
            t,
            DVec3::new(20.0 * t, 0.0, 0.5),
            0.0,
            DVec3::new(20.0, 0.0, 0.0),
        );
        let dets: Vec<_> = (0..8)
            .map(|k| {
                let p = DVec3::new(15.0 + 7.0 * k as f64, 6.0 * (k as f64 - 3.5), 0.5);
                detection_of(&e, p, DVec3::ZERO, 0.0, k)
            })
            .collect();
        out.clear();
        rec.step(&e, &dets, &mut out);
        assert!(rec.compensated().iter().all(|c| !c.moving));
    }
    assert!(out.is_empty(), "{out:?}");
}

#[test]
fn radar_dbscan_clusters_targets() {
    let mut rec = RadarRecognition::new(&RadarRecognitionConfig::default()).unwrap();
    let e = ego(0.0, DVec3::new(0.0, 0.0, 0.5), 0.0, DVec3::ZERO);
    let mut dets = Vec::new();
    // Target A: 3 detections on a car at 20 m moving away at 5 m/s.
    for dy in [-0.6, 0.0, 0.6] {
        dets.push(detection_of(
            &e,
            DVec3::new(20.0, 2.0 + dy, 0.5),
            DVec3::new(5.0, 0.0, 0.0),
            10.0,
            1,
        ));
    }
    // Target B: same place but approaching at 5 m/s (separated by velocity).
    for dx in [0.0, 0.5] {
        dets.push(detection_of(
            &e,
            DVec3::new(21.0 + dx, 3.0, 0.5),
            DVec3::new(-5.0, 0.0, 0.0),
            10.0,
            2,
        ));
    }
    // Target C: 40 m away.
    dets.push(detection_of(
        &e,
        DVec3::new(40.0, -10.0, 0.5),
        DVec3::new(0.0, 3.0, 0.0),
        0.0,
        3,
    ));
    rec.detect(&e, &dets);
    let cl = rec.clusters();
    assert_eq!(cl.len(), 3, "{cl:?}");
    let mut sizes: Vec<_> = cl
        .iter()
        .map(|c| (c.ground_truth_id.unwrap(), c.n_detections))
        .collect();
    sizes.sort();
    assert_eq!(sizes, vec![(1, 3), (2, 2), (3, 1)]);
}

#[test]
fn radar_ghost_behind_guardrail_and_below_ground_rejected() {
    let mut rec = RadarRecognition::new(&RadarRecognitionConfig::default()).unwrap();
    let mut out = Vec::new();
    let v_s = DVec3::new(15.0, 0.0, 0.0);
    let v_t = DVec3::new(10.0, 0.0, 0.0);
    let dt = 0.05;
    let mut ghost_seen = false;
    for s in 0..30 {
        let t = dt * s as f64;
        let e = ego(t, DVec3::new(15.0 * t, 0.0, 0.5), 0.0, v_s);
        let mut dets = Vec::new();
        // Guardrail at y = −5 (fixed), detections every 1.5 m from 5 m to 60 m ahead.
        for k in 0..37 {
            let x = e.sensor_pose.position.x + 5.0 + 1.5 * k as f64;
            dets.push(detection_of(
                &e,
                DVec3::new(x, -5.0, 0.6),
                DVec3::ZERO,
                5.0,
                100,
            ));
        }
        // Real target at y = −2.5 and its mirror image in the guardrail at y = −7.5.
        let xt = 30.0 + 10.0 * t;
        dets.push(detection_of(&e, DVec3::new(xt, -2.5, 0.5), v_t, 10.0, 1));
        // The mirror path is longer; its Doppler is that of the mirrored target.
        dets.push(detection_of(&e, DVec3::new(xt, -7.5, 0.5), v_t, 5.0, 1));
        // Road-surface multipath image below the ground.
        dets.push(detection_of(&e, DVec3::new(xt, -2.5, -3.0), v_t, 5.0, 1));
        out.clear();
        rec.step(&e, &dets, &mut out);
        assert!(rec.compensated().last().unwrap().below_ground);
        assert_eq!(rec.guardrails().len(), 1, "{:?}", rec.guardrails());
        ghost_seen |= rec.clusters().iter().any(|c| c.ghost);
        for o in &out {
            let p = e.sensor_pose.transform_point(pos_of(o));
            assert!(p.y > -4.0, "ghost reported at {p:?}");
        }
    }
    assert!(ghost_seen);
    assert_eq!(out.len(), 1, "{out:?}");
    let e = ego(dt * 29.0, DVec3::new(15.0 * dt * 29.0, 0.0, 0.5), 0.0, v_s);
    let p = e.sensor_pose.transform_point(pos_of(&out[0]));
    assert!((p.y + 2.5).abs() < 0.5, "{p:?}");
}

#[test]
fn radar_constant_velocity_target_tracked() {
    let cfg = RadarRecognitionConfig {
        range_std_m: 0.15,
        azimuth_std_rad: 0.005,
        range_rate_std_m_s: 0.1,
        ..Default::default()
    };
    let mut rec = RadarRecognition::new(&cfg).unwrap();
    let mut rng = SmallRng::seed_from_u64(42);
    let n_r = Normal::new(0.0, 0.15).unwrap();
    let n_a = Normal::new(0.0, 0.005).unwrap();
    let n_v = Normal::new(0.0, 0.1).unwrap();
    let v_s = DVec3::new(10.0, 0.0, 0.0);
    let v_t = DVec3::new(-5.0, 2.0, 0.0);
    let dt = 0.05;
    let mut out = Vec::new();
    let mut e = ego(0.0, DVec3::ZERO, 0.0, v_s);
    for s in 0..60 {
        let t = dt * s as f64;
        e = ego(t, DVec3::new(10.0 * t, 0.0, 0.5), 0.0, v_s);
        let p = DVec3::new(40.0, -5.0, 0.5) + v_t * t;
        let mut d = detection_of(&e, p, v_t, 10.0, 5);
        d.range_m += n_r.sample(&mut rng);
        d.azimuth_rad += n_a.sample(&mut rng);
        d.range_rate_m_s += n_v.sample(&mut rng);
        out.clear();
        rec.step(&e, &[d], &mut out);
    }
    assert_eq!(out.len(), 1);
    let o = &out[0];
    // Velocity relative to the (non-rotating) sensor: v_t − v_s.
    let rel = vel_of(o);
    let err = (rel - (v_t - v_s)).truncate().length();
    eprintln!("radar CV velocity error {err:.3} m/s ({rel:?})");
    assert!(err < 0.3, "velocity error {err} ({rel:?})");
    // The reported position is the box centre behind the reflecting face (OSI base.position).
    let p_last = DVec3::new(40.0, -5.0, 0.5) + v_t * (dt * 59.0);
    let p_expect = e.sensor_pose.inverse_transform_point(box_centre_behind(
        o,
        e.sensor_pose.position,
        p_last,
        v_t,
    ));
    assert!(
        (pos_of(o) - p_expect).truncate().length() < 0.5,
        "{:?} vs {p_expect:?}",
        pos_of(o)
    );
    let h = o.header.as_ref().unwrap();
    assert_eq!(h.ground_truth_id[0].value, Some(5));
    assert!(h.existence_probability.unwrap() > 0.95);
    assert!((h.age.unwrap() - 59.0 * dt).abs() < 1e-9);
    assert_eq!(
        o.movement_state,
        Some(osi3::detected_moving_object::MovementState::Moving as i32)
    );
    assert_eq!(
        o.candidate[0].r#type,
        Some(osi3::moving_object::Type::Vehicle as i32)
    );
}

#[test]
fn radar_single_frame_false_alarm_not_confirmed() {
    let mut rec = RadarRecognition::new(&RadarRecognitionConfig::default()).unwrap();
    let mut out = Vec::new();
    let mut rng = SmallRng::seed_from_u64(3);
    for s in 0..20 {
        let t = 0.05 * s as f64;
        let e = ego(t, DVec3::ZERO, 0.0, DVec3::ZERO);
        // Each frame one false alarm at a random place with a random Doppler.
        let p = DVec3::new(
            rng.random_range(10.0..80.0),
            rng.random_range(-20.0..20.0),
            0.5,
        );
        let v = DVec3::new(
            rng.random_range(-20.0..20.0),
            rng.random_range(-5.0..5.0),
            0.0,
        );
        let d = detection_of(&e, p, v, 0.0, osiris_proto::INVALID_ID);
        out.clear();
        rec.step(&e, &[d], &mut out);
        assert!(out.is_empty(), "step {s}: {out:?}");
    }
}

#[test]
fn radar_existence_rises_with_hits_and_falls_with_misses() {
    let mut rec = RadarRecognition::new(&RadarRecognitionConfig::default()).unwrap();
    let mut out = Vec::new();
    let v_t = DVec3::new(3.0, 0.0, 0.0);
    let mut history = Vec::new();
    for s in 0..14 {
        let t = 0.05 * s as f64;
        let e = ego(t, DVec3::ZERO, 0.0, DVec3::ZERO);
        let p = DVec3::new(25.0, 1.0, 0.5) + v_t * t;
        let dets = if s < 8 {
            vec![detection_of(&e, p, v_t, 10.0, 1)]
        } else {
            Vec::new()
        };
        out.clear();
        rec.step(&e, &dets, &mut out);
        let ex: Vec<_> = rec.track_existence().collect();
        history.push(ex.first().map(|x| x.1));
        if s >= 8 && !out.is_empty() {
            let h = out[0].header.as_ref().unwrap();
            assert_eq!(
                h.measurement_state,
                Some(osi3::detected_item_header::MeasurementState::Predicted as i32)
            );
        }
    }
    let h: Vec<f64> = history.iter().map_while(|x| *x).collect();
    assert!(h.len() >= 9, "{history:?}");
    for k in 1..8 {
        assert!(h[k] > h[k - 1], "not rising at {k}: {h:?}");
    }
    for k in 8..h.len() {
        assert!(h[k] < h[k - 1], "not falling at {k}: {h:?}");
    }
    assert!(h[7] > 0.99 && h[h.len() - 1] < h[7]);
    // Deleted after the coast limit.
    assert!(history.last().unwrap().is_none(), "{history:?}");
}

#[test]
fn radar_config_errors_name_the_key() {
    let c = RadarRecognitionConfig {
        dbscan_eps: 0.0,
        ..Default::default()
    };
    match RadarRecognition::new(&c) {
        Err(ModelError::Config(m)) => assert!(m.contains("radar.recognition.dbscan_eps"), "{m}"),
        other => panic!("{other:?}"),
    }
    let mut c = RadarRecognitionConfig::default();
    c.tracker.detection_probability = 1.5;
    match RadarRecognition::new(&c) {
        Err(ModelError::Config(m)) => assert!(m.contains("tracker.detection_probability"), "{m}"),
        other => panic!("{other:?}"),
    }
    assert!(serde_json::from_str::<RadarRecognitionConfig>(r#"{"eps": 1}"#).is_err());
}

#[test]
fn tracks_survive_a_rebased_fixed_frame() {
    // The scene frame moves its origin by (−100, 0, 0) at t = 1 s: every fixed-frame coordinate
    // jumps by +100 m in x. The radar track must keep its id and its sensor-frame state.
    let mut rec = RadarRecognition::new(&RadarRecognitionConfig::default()).unwrap();
    let v_s = DVec3::new(10.0, 0.0, 0.0);
    let v_t = DVec3::new(15.0, 0.5, 0.0);
    let mut out = Vec::new();
    let mut ids = Vec::new();
    for s in 0..40 {
        let t = 0.05 * s as f64;
        let shift = if t >= 1.0 {
            DVec3::new(100.0, 0.0, 0.0)
        } else {
            DVec3::ZERO
        };
        let e = ego(t, DVec3::new(10.0 * t, 0.0, 0.5) + shift, 0.0, v_s);
        let p = DVec3::new(30.0, 2.0, 0.5) + v_t * t + shift;
        out.clear();
        rec.step(&e, &[detection_of(&e, p, v_t, 10.0, 1)], &mut out);
        if let Some(o) = out.first() {
            ids.push(o.header.as_ref().unwrap().tracking_id.unwrap().value);
            let expect = e.sensor_pose.inverse_transform_point(box_centre_behind(
                o,
                e.sensor_pose.position,
                p,
                v_t,
            ));
            assert!(
                (pos_of(o) - expect).truncate().length() < 0.5,
                "t={t}: {:?} vs {expect:?}",
                pos_of(o)
            );
        }
    }
    assert!(
        ids.len() > 30 && ids.iter().all(|i| *i == ids[0]),
        "{ids:?}"
    );
}

// ------------------------------------------------------------------------------------------------
// Detections → detected objects (OSI 3.8.0 `object_id` semantics)

/// The tracking id of the reported object whose ground truth is `gt`.
fn tracking_id_of(out: &[osi3::DetectedMovingObject], gt: u64) -> Option<u64> {
    out.iter()
        .find(|o| {
            o.header
                .as_ref()
                .unwrap()
                .ground_truth_id
                .iter()
                .any(|i| i.value == Some(gt))
        })
        .and_then(|o| o.header.as_ref().unwrap().tracking_id?.value)
}

/// A LiDAR point belongs to the reported object whose box it was part of: none before the track
/// is confirmed (M = 3 of N = 5), the car's tracking id afterwards; ground points never.
#[test]
fn lidar_points_refer_to_the_reported_object_of_their_cluster() {
    let mut rec = LidarRecognition::new(&LidarRecognitionConfig::default()).unwrap();
    let sensor = DVec3::new(0.0, 0.0, SENSOR_HEIGHT_M);
    let car = Boxx::on_ground(0.0, DVec2::new(15.0, 2.0), 0.2, CAR, 7);
    let mut out = Vec::new();
    for s in 0..4 {
        out.clear();
        let pts = lidar_scan(sensor, [0.0; 3], &[car], s);
        rec.step(
            &ego(0.1 * s as f64, sensor, 0.0, DVec3::ZERO),
            &pts,
            &mut out,
        );
        let objs = rec.detection_objects();
        assert_eq!(objs.len(), pts.len());
        let on_ground: Vec<_> = (0..pts.len())
            .filter(|&i| pts[i].object_id == osiris_proto::INVALID_ID)
            .collect();
        assert!(on_ground.len() > 1000);
        assert!(on_ground.iter().all(|&i| objs[i].is_none()), "step {s}");
        let on_car: Vec<_> = (0..pts.len()).filter(|&i| pts[i].object_id == 7).collect();
        assert!(on_car.len() > 100, "{}", on_car.len());
        if s < 2 {
            // Tentative: nothing reported, nothing associated.
            assert!(out.is_empty(), "step {s}: {out:?}");
            assert!(objs.iter().all(Option::is_none), "step {s}");
        } else {
            let tid = tracking_id_of(&out, 7).expect("the car is reported");
            // Car points more than 0.2 m above the road (ground segmentation removes those within
            // 0.15 m of the plane, noise 2 cm) are all the car's.
            let height = |i: usize| SENSOR_HEIGHT_M + pts[i].position_m.z;
            let above: Vec<_> = on_car
                .iter()
                .copied()
                .filter(|&i| height(i) > 0.2)
                .collect();
            let n = above.iter().filter(|&&i| objs[i] == Some(tid)).count();
            assert_eq!(
                n,
                above.len(),
                "step {s}: {n} of {} car points",
                above.len()
            );
            assert!(above.len() * 10 > on_car.len() * 8);
            // Every associated point names a reported object.
            assert!(objs.iter().flatten().all(|&t| t == tid));
            assert_eq!(rec.reported_ground_truth(), &[(tid, Some(7))]);
        }
    }
    // The car gone: the coasting track is still reported (PREDICTED) with no points and no ground
    // truth in its header, but its last ground truth is kept for the output assembly.
    out.clear();
    let pts = lidar_scan(sensor, [0.0; 3], &[], 9);
    rec.step(&ego(0.4, sensor, 0.0, DVec3::ZERO), &pts, &mut out);
    assert_eq!(out.len(), 1);
    let h = out[0].header.as_ref().unwrap();
    assert!(h.ground_truth_id.is_empty());
    assert_eq!(
        rec.reported_ground_truth(),
        &[(h.tracking_id.unwrap().value.unwrap(), Some(7))]
    );
    assert!(rec.detection_objects().iter().all(Option::is_none));
}

/// A radar detection belongs to the reported object whose cluster it was part of; stationary
/// clutter (not tracked by default) and a below-ground ghost belong to none.
#[test]
fn radar_detections_refer_to_the_reported_object_of_their_cluster() {
    let mut rec = RadarRecognition::new(&RadarRecognitionConfig::default()).unwrap();
    let mut out = Vec::new();
    let v_t = DVec3::new(5.0, 0.0, 0.0);
    for s in 0..5 {
        let t = 0.05 * s as f64;
        let e = ego(t, DVec3::new(0.0, 0.0, 0.5), 0.0, DVec3::ZERO);
        let c = DVec3::new(20.0, 2.0, 0.5) + v_t * t;
        let mut dets: Vec<_> = [-0.6, 0.0, 0.6]
            .iter()
            .map(|dy| detection_of(&e, c + DVec3::new(0.0, *dy, 0.0), v_t, 10.0, 1))
            .collect();
        // Stationary clutter (a post) and a below-ground mirror image of the car.
        dets.push(detection_of(
            &e,
            DVec3::new(30.0, -8.0, 0.5),
            DVec3::ZERO,
            0.0,
            2,
        ));
        dets.push(detection_of(&e, c - DVec3::new(0.0, 0.0, 3.0), v_t, 0.0, 1));
        out.clear();
        rec.step(&e, &dets, &mut out);
        let objs = rec.detection_objects();
        assert_eq!(objs.len(), dets.len());
        assert_eq!(&objs[3..], &[None, None], "step {s}");
        match tracking_id_of(&out, 1) {
            None => {
                assert!(s < 2, "step {s}: the target is not reported: {out:?}");
                assert!(objs.iter().all(Option::is_none));
            }
            Some(tid) => assert_eq!(&objs[..3], &[Some(tid); 3], "step {s}"),
        }
    }
    assert!(tracking_id_of(&out, 1).is_some());
}
