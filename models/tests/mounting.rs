//! Mounting, calibration and timing as physical effects (physics.md §7): the closed forms of the
//! output shift of a miscalibrated sensor, for the radar, the LiDAR and the camera.
//!
//! * `<sensor>.extrinsic_error`: a yaw error δ (the true sensor frame turned by δ about the nominal
//!   z axis) reports a target at azimuth θ at θ − δ; a translation error t (true origin at t in
//!   the nominal frame) reports a point p at p − t; a camera turned by δ sees a target at the image
//!   centre move by f·tan δ pixels.
//! * `<sensor>.time_offset`: the sensor measures at t + Δt, Δt = offset + drift·t, so a target
//!   moving at v is reported v·Δt further along, while the output keeps the stamped time t.
//!
//! Each case runs the same scene with a calibrated sensor (all zero) and a miscalibrated one and
//! compares the two outputs against the closed form; the switch off gives the calibrated output.

mod common;
use common::{moving_object, sun};

use std::f64::consts::PI;

use osiris_models::frames::Calibration;
use osiris_models::radar::RadarSensor;
use osiris_models::sensor::{ModelMode, Mounting};
use osiris_models::{SensorConfig, SensorKind, SensorModel, StepOutput};
use osiris_proto::{osi3, timestamp_from_seconds};

fn view_at(t_s: f64, objects: Vec<osi3::MovingObject>) -> osi3::SensorView {
    osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(timestamp_from_seconds(t_s)),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(timestamp_from_seconds(t_s)),
            moving_object: objects,
            environmental_conditions: Some(sun(PI, 40f64.to_radians())),
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn step(sensor: &mut dyn SensorModel, v: &osi3::SensorView) -> StepOutput {
    let t = v
        .timestamp
        .as_ref()
        .map(osiris_proto::timestamp_to_seconds)
        .unwrap_or(0.0);
    common::step_at(sensor, v, t, 0.05)
}

fn config(kind: SensorKind, h: f64, calibration: Calibration) -> SensorConfig {
    let mut c = SensorConfig::default_for(kind);
    c.mode = ModelMode::Physical;
    c.mounting = Mounting {
        position_m: [0.0, 0.0, h],
        orientation_rad: [0.0; 3],
    };
    c.seed = Some(3);
    c.calibration = calibration;
    c
}

// ---------------------------------------------------------------------------------------------
// Radar

/// Trihedral (edge 0.1 m) `oid` at range `r`, azimuth `az_deg`, 1 m up, facing the sensor, moving
/// with `vel`.
fn trihedral(oid: u64, r: f64, az_deg: f64, vel: [f64; 3]) -> osi3::MovingObject {
    let az = az_deg.to_radians();
    moving_object(
        "osiris:trihedral?edge_m=0.1",
        oid,
        [r * az.cos(), r * az.sin(), 1.0],
        az + PI,
        [0.09, 0.15, 0.15],
        vel,
    )
}

fn radar_config(calibration: Calibration) -> SensorConfig {
    let mut c = config(SensorKind::Radar, 1.0, calibration);
    c.fov_horizontal_rad = 120f64.to_radians();
    c.fov_vertical_rad = 30f64.to_radians();
    // Free space: no road bounce, no gas loss (the direct path alone).
    for e in ["radar.ground_multipath", "radar.atmospheric_absorption"] {
        c.effects.insert(e.into(), false);
    }
    c
}

/// One radar step: (range, azimuth, elevation) of the strongest path of every object, and of the
/// strongest detection of every object (SensorData), by object id; and the output.
struct RadarRun {
    paths: Vec<(u64, [f64; 3])>,
    detections: Vec<(u64, [f64; 3])>,
    out: StepOutput,
}

fn radar_run(cfg: SensorConfig, v: &osi3::SensorView, ids: &[u64]) -> RadarRun {
    let mut s = RadarSensor::new(cfg).expect("radar");
    let out = step(&mut s, v);
    let paths = ids
        .iter()
        .map(|&oid| {
            let p = s
                .last_paths()
                .iter()
                .filter(|p| p.object_id == oid)
                .max_by(|a, b| a.amplitude.norm().total_cmp(&b.amplitude.norm()))
                .unwrap_or_else(|| panic!("a path off object {oid}"));
            (oid, [p.range_m, p.rx_azimuth_rad, p.rx_elevation_rad])
        })
        .collect();
    let radar = out.perception.radar.as_ref().expect("radar perception");
    let detections = ids
        .iter()
        .map(|&oid| {
            let p = radar
                .peak
                .iter()
                .filter(|p| p.object_id.and_then(|i| i.value) == Some(oid))
                .max_by(|a, b| a.snr_db.unwrap().total_cmp(&b.snr_db.unwrap()))
                .unwrap_or_else(|| panic!("a detection of object {oid}"));
            (
                oid,
                [
                    p.range_m.unwrap(),
                    p.azimuth_rad.unwrap(),
                    p.elevation_rad.unwrap(),
                ],
            )
        })
        .collect();
    RadarRun {
        paths,
        detections,
        out,
    }
}

#[test]
fn radar_yaw_error_reports_a_target_at_theta_minus_delta() {
    let delta_deg = 2.0;
    let azimuths = [-25.0, 0.0, 18.0];
    let objects: Vec<_> = azimuths
        .iter()
        .enumerate()
        .map(|(k, &az)| trihedral(10 + k as u64, 18.0 + 4.0 * k as f64, az, [0.0; 3]))
        .collect();
    let ids: Vec<u64> = (0..azimuths.len() as u64).map(|k| 10 + k).collect();
    let v = view_at(0.0, objects);
    let reference = radar_run(radar_config(Calibration::default()), &v, &ids);
    let yawed = Calibration {
        yaw_deg: delta_deg,
        ..Default::default()
    };
    let run = radar_run(radar_config(yawed), &v, &ids);
    for (k, &az) in azimuths.iter().enumerate() {
        let (r0, r1) = (reference.paths[k].1, run.paths[k].1);
        // The path: the same scatterer, seen from a frame turned by δ.
        let shift = (r1[1] - r0[1]).to_degrees();
        assert!(
            (shift + delta_deg).abs() < 0.02,
            "target at {az}°: path azimuth moved by {shift:.4}°, closed form −{delta_deg}°"
        );
        assert!(
            (r1[0] - r0[0]).abs() < 1e-3,
            "range changed: {r0:?} → {r1:?}"
        );
        // The detection: the angle estimate follows (within its interpolation error).
        let (d0, d1) = (reference.detections[k].1, run.detections[k].1);
        let shift = (d1[1] - d0[1]).to_degrees();
        assert!(
            (shift + delta_deg).abs() < 0.25,
            "target at {az}°: detected azimuth moved by {shift:.3}°, closed form −{delta_deg}°"
        );
    }
    // The output still says it is mounted where the configuration says.
    let m = run.out.sensor_data.mounting_position.expect("mounting");
    assert_eq!(m.orientation.and_then(|o| o.yaw), Some(0.0));
    // The switch off: the calibrated sensor's paths.
    let mut off = radar_config(yawed);
    off.effects.insert("radar.extrinsic_error".into(), false);
    let off = radar_run(off, &v, &ids);
    assert_eq!(off.paths, reference.paths);
}

#[test]
fn radar_translation_error_reports_a_target_off_by_minus_the_offset() {
    let t = [0.0, 0.3, 0.0];
    let (r, az) = (15.0, 10.0);
    let v = view_at(0.0, vec![trihedral(10, r, az, [0.0; 3])]);
    let reference = radar_run(radar_config(Calibration::default()), &v, &[10]);
    let shifted = Calibration {
        x_m: t[0],
        y_m: t[1],
        z_m: t[2],
        ..Default::default()
    };
    let run = radar_run(radar_config(shifted), &v, &[10]);
    // The scatterer of the reference path, moved into the frame whose origin is at t.
    let [r0, a0, e0] = reference.paths[0].1;
    let p = r0 * glam::DVec3::new(e0.cos() * a0.cos(), e0.cos() * a0.sin(), e0.sin());
    let q = p - glam::DVec3::from(t);
    let (r_want, az_want) = (q.length(), q.y.atan2(q.x));
    let [r1, a1, _] = run.paths[0].1;
    assert!(
        (r1 - r_want).abs() < 2e-3,
        "range {r1:.4} m, closed form {r_want:.4} m"
    );
    assert!(
        (a1 - az_want).to_degrees().abs() < 0.02,
        "azimuth {:.4}°, closed form {:.4}° (calibrated {:.4}°)",
        a1.to_degrees(),
        az_want.to_degrees(),
        a0.to_degrees()
    );
    // A lateral offset moves the target's azimuth by about −t_y·cos θ / R (1.1° here).
    assert!((a1 - a0).to_degrees() < -1.0);
}

#[test]
fn radar_time_offset_moves_a_target_by_v_dt_and_keeps_the_timestamp() {
    // Δt = 50 ms + 500 ppm × 100 s = 100 ms; the target recedes at 10 m/s: 1 m further.
    let (t_s, v_m_s) = (100.0, 10.0);
    let cal = Calibration {
        time_offset_s: 0.05,
        time_drift_ppm: 500.0,
        ..Default::default()
    };
    let dt = cal.time_offset_at(t_s);
    assert!((dt - 0.1).abs() < 1e-12);
    let v = view_at(t_s, vec![trihedral(10, 20.0, 0.0, [v_m_s, 0.0, 0.0])]);
    let reference = radar_run(radar_config(Calibration::default()), &v, &[10]);
    let run = radar_run(radar_config(cal), &v, &[10]);
    let shift = run.paths[0].1[0] - reference.paths[0].1[0];
    assert!(
        (shift - v_m_s * dt).abs() < 2e-3,
        "path range moved by {shift:.4} m, v·Δt = {:.4} m",
        v_m_s * dt
    );
    let shift = run.detections[0].1[0] - reference.detections[0].1[0];
    assert!(
        (shift - v_m_s * dt).abs() < 0.05,
        "detected range moved by {shift:.4} m, v·Δt = {:.4} m",
        v_m_s * dt
    );
    // Stamped with the ground truth's time, not the sensor clock's.
    assert_eq!(
        run.out.sensor_data.timestamp,
        Some(timestamp_from_seconds(t_s))
    );
    let mut off = radar_config(cal);
    off.effects.insert("radar.time_offset".into(), false);
    assert_eq!(radar_run(off, &v, &[10]).paths, reference.paths);
}

// ---------------------------------------------------------------------------------------------
// LiDAR

/// A 1 m high LiDAR with a dense MEMS raster (10° × 4°, 0.05° × 0.1° spacing) around boresight.
fn lidar_config(calibration: Calibration) -> SensorConfig {
    use osiris_models::lidar::LidarConfig;
    use osiris_models::lidar::scan::{MemsPattern, ScanPattern};
    let mut c = config(SensorKind::Lidar, 1.0, calibration);
    c.range_m = 100.0;
    c.fov_horizontal_rad = 2.0 * PI;
    c.fov_vertical_rad = PI;
    c.update_cycle_s = 0.1;
    let mut l = LidarConfig {
        scan: Some(ScanPattern::Mems(MemsPattern {
            fov_horizontal_rad: 10f64.to_radians(),
            fov_vertical_rad: 4f64.to_radians(),
            lines: 40,
            points_per_line: 200,
            frame_time_s: 0.05,
            bidirectional: false,
            centre_rad: [0.0, 0.0],
        })),
        ..Default::default()
    };
    l.beam.sub_rays = Some(1);
    c.lidar = Some(l);
    c.effects.insert("lidar.dropped_rays".into(), false);
    c
}

/// A 1 m × 1 m board `oid` with its face centre at `pos`, facing the sensor, moving with `vel`.
fn board(oid: u64, pos: [f64; 3], vel: [f64; 3]) -> osi3::MovingObject {
    moving_object(
        "osiris:board?width_m=1&height_m=1&thickness_m=0&mount=none&material=lambertian_50",
        oid,
        pos,
        pos[1].atan2(pos[0]) + PI,
        [0.01, 1.0, 1.0],
        vel,
    )
}

/// The points on `oid` (sensor frame, m).
fn points_on(out: &StepOutput, oid: u64) -> Vec<glam::DVec3> {
    let c = out.perception.lidar.as_ref().expect("lidar perception");
    (0..c.x_m.len())
        .filter(|&i| c.object_id[i] == oid)
        .map(|i| glam::DVec3::new(c.x_m[i].into(), c.y_m[i].into(), c.z_m[i].into()))
        .collect()
}

fn mean_of(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn lidar_yaw_error_turns_the_points_by_minus_delta() {
    let delta_deg = 1.5;
    let az = 1.0f64.to_radians();
    let v = view_at(
        1.0,
        vec![board(7, [20.0 * az.cos(), 20.0 * az.sin(), 1.0], [0.0; 3])],
    );
    let mean_az = |cal: Calibration| {
        let (out, _) = common::lidar_step(lidar_config(cal), &v);
        let p = points_on(&out, 7);
        assert!(p.len() > 200, "{} points on the board", p.len());
        mean_of(&p.iter().map(|p| p.y.atan2(p.x)).collect::<Vec<_>>()).to_degrees()
    };
    let a0 = mean_az(Calibration::default());
    let a1 = mean_az(Calibration {
        yaw_deg: delta_deg,
        ..Default::default()
    });
    // 0.05° columns: the board's mean azimuth is known to a fraction of a column.
    assert!(
        (a1 - a0 + delta_deg).abs() < 0.05,
        "mean azimuth {a0:.3}° → {a1:.3}°, closed form −{delta_deg}°"
    );
}

#[test]
fn lidar_time_offset_moves_a_crossing_board_by_v_dt() {
    let (vy, dt) = (5.0, 0.08);
    let v = view_at(1.0, vec![board(7, [20.0, 0.0, 1.0], [0.0, vy, 0.0])]);
    let mean_y = |cal: Calibration| {
        let (out, _) = common::lidar_step(lidar_config(cal), &v);
        let p = points_on(&out, 7);
        assert!(p.len() > 200, "{} points on the board", p.len());
        mean_of(&p.iter().map(|p| p.y).collect::<Vec<_>>())
    };
    let y0 = mean_y(Calibration::default());
    let y1 = mean_y(Calibration {
        time_offset_s: dt,
        ..Default::default()
    });
    assert!(
        (y1 - y0 - vy * dt).abs() < 0.03,
        "mean lateral position {y0:.3} → {y1:.3} m, v·Δt = {:.3} m",
        vy * dt
    );
}

// ---------------------------------------------------------------------------------------------
// Camera

const CAM_W: usize = 192;
const CAM_H: usize = 144;
const CAM_HFOV_DEG: f64 = 60.0;

fn camera_config(calibration: Calibration) -> SensorConfig {
    let mut c = config(SensorKind::Camera, 1.3, calibration);
    c.fov_horizontal_rad = CAM_HFOV_DEG.to_radians();
    c.fov_vertical_rad = (CAM_HFOV_DEG * CAM_H as f64 / CAM_W as f64).to_radians();
    let cam = serde_json::json!({
        "width_px": CAM_W,
        "height_px": CAM_H,
        "exposure_s": 0.004,
        "recognition": {"random_draw": false},
    });
    c.camera = Some(serde_json::from_value(cam).expect("camera config"));
    // A pinhole image: u = c_u − f·tan(azimuth).
    c.effects.insert("camera.distortion".into(), false);
    c
}

/// Horizontal centre of the visible box of `oid` (the recognition's measurement), px.
fn box_centre_u(s: &osiris_models::camera::CameraSensor, oid: u64) -> f64 {
    let m = s
        .last_measurements()
        .iter()
        .find(|m| m.ground_truth_id == oid)
        .unwrap_or_else(|| panic!("object {oid} seen"));
    0.5 * (m.box_px[0] + m.box_px[2])
}

#[test]
fn camera_yaw_error_moves_the_image_by_f_tan_delta() {
    use osiris_models::camera::CameraSensor;
    let delta_deg: f64 = 3.0;
    let mut car = moving_object(
        "osiris:car",
        30,
        [15.0, 0.0, 0.75],
        0.0,
        [4.5, 1.8, 1.5],
        [0.0; 3],
    );
    car.r#type = Some(osi3::moving_object::Type::Vehicle as i32);
    let v = view_at(1.0, vec![car]);
    let u = |cal: Calibration| {
        let mut s = CameraSensor::new(camera_config(cal)).expect("camera");
        step(&mut s, &v);
        box_centre_u(&s, 30)
    };
    let u0 = u(Calibration::default());
    let u1 = u(Calibration {
        yaw_deg: delta_deg,
        ..Default::default()
    });
    // The camera turned left by δ sees the car ahead δ to its right: u grows by f·tan δ.
    let f_px = 0.5 * CAM_W as f64 / (0.5 * CAM_HFOV_DEG).to_radians().tan();
    let want = f_px * delta_deg.to_radians().tan();
    assert!(
        (u1 - u0 - want).abs() < 1.0,
        "box centre u {u0:.1} → {u1:.1} px, f·tan δ = {want:.2} px"
    );
}

// ---------------------------------------------------------------------------------------------
// Radar online azimuth calibration

/// A host car (id 1) at `x` m driving along +x at `v` m/s; the trihedral posts (ids 100…) stand
/// every 8 m on both sides of the road, 5 m off its centre line, 0.5 m up, facing the host.
fn drive_view(t_s: f64, x: f64, v: f64) -> osi3::SensorView {
    let mut host = moving_object(
        "osiris:car",
        1,
        [x, 0.0, 0.75],
        0.0,
        [4.5, 1.8, 1.5],
        [v, 0.0, 0.0],
    );
    host.r#type = Some(osi3::moving_object::Type::Vehicle as i32);
    let mut objects = vec![host];
    for k in 0..24u64 {
        for (side, y) in [(0u64, 5.0), (1, -5.0)] {
            let px = 12.0 + 8.0 * k as f64;
            objects.push(moving_object(
                "osiris:trihedral?edge_m=0.1",
                100 + 2 * k + side,
                [px, y, 0.5],
                PI,
                [0.09, 0.15, 0.15],
                [0.0; 3],
            ));
        }
    }
    let mut view = view_at(t_s, objects);
    view.host_vehicle_id = Some(osiris_proto::id(1));
    view.global_ground_truth.as_mut().unwrap().host_vehicle_id = Some(osiris_proto::id(1));
    view
}

/// A front radar 0.5 m up on a host driving at 15 m/s past trihedral posts on both sides; its
/// bracket turns it 1° to the left. The online calibration recovers the 1° within 0.1°, and the
/// corrected azimuths are the raw ones plus the estimate.
#[test]
fn online_calibration_recovers_a_one_degree_yaw_error_on_a_drive() {
    let yaw_deg = 1.0;
    let cfg = |online: bool| {
        let mut c = config(
            SensorKind::Radar,
            -0.25,
            Calibration {
                yaw_deg,
                ..Default::default()
            },
        );
        c.mounting.position_m[0] = 2.3;
        c.effects
            .insert("radar.mounting_misalignment".into(), online);
        c
    };
    let (v, dt) = (15.0, 0.05);
    let mut on = RadarSensor::new(cfg(true)).expect("radar");
    let mut off = RadarSensor::new(cfg(false)).expect("radar");
    let mut last = (StepOutput::default(), StepOutput::default());
    for k in 0..30 {
        let t = k as f64 * dt;
        let view = drive_view(t, v * t, v);
        last = (step(&mut on, &view), step(&mut off, &view));
    }
    let radar = last.0.perception.radar.as_ref().expect("radar perception");
    let est = radar
        .azimuth_misalignment_rad
        .expect("the estimate is reported")
        .to_degrees();
    let used = radar.misalignment_detections.unwrap_or(0);
    println!(
        "online calibration: {est:.4}° from {used} stationary detections in {} cycles",
        on.misalignment().cycles_used
    );
    assert!(used >= 100, "{used} detections used");
    assert!(
        (est - yaw_deg).abs() < 0.1,
        "estimated misalignment {est:.4}°, true {yaw_deg}°"
    );
    // Off: no estimate, raw azimuths; on: the same peaks, each turned by the estimate.
    let raw = last.1.perception.radar.as_ref().unwrap();
    assert_eq!(raw.azimuth_misalignment_rad, None);
    assert_eq!(raw.peak.len(), radar.peak.len());
    for (a, b) in radar.peak.iter().zip(&raw.peak) {
        let d = (a.azimuth_rad.unwrap() - b.azimuth_rad.unwrap()).to_degrees();
        assert!(
            (d - est).abs() < 1e-9,
            "corrected − raw = {d}°, estimate {est}°"
        );
    }
}

/// The `calibration` block: keys with units, zero by default, out-of-range and unknown keys are
/// errors naming the key.
#[test]
fn calibration_block_is_checked_and_named() {
    let json = |cal: &str| {
        format!(
            r#"{{"kind": "radar", "mode": "physical", "range_m": 100, "fov_horizontal_rad": 1.5,
                "fov_vertical_rad": 0.2, "update_cycle_s": 0.05,
                "mounting": {{"position_m": [3.7, 0, 0.5]}}{cal}}}"#
        )
    };
    let c = SensorConfig::from_json_str(&json(
        r#", "calibration": {"yaw_deg": 0.4, "y_m": 0.02, "time_offset_s": -0.01, "time_drift_ppm": 20}"#,
    ))
    .expect("a valid calibration");
    assert_eq!(c.calibration.yaw_deg, 0.4);
    assert_eq!(c.calibration.pitch_deg, 0.0);
    assert_eq!(
        SensorConfig::from_json_str(&json("")).unwrap().calibration,
        Calibration::default()
    );
    let err = SensorConfig::from_json_str(&json(r#", "calibration": {"yaw_deg": 25}"#))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("calibration.yaw_deg") && err.contains("25"),
        "{err}"
    );
    let err = SensorConfig::from_json_str(&json(r#", "calibration": {"time_offset_s": 3}"#))
        .unwrap_err()
        .to_string();
    assert!(err.contains("calibration.time_offset_s"), "{err}");
    let err = SensorConfig::from_json_str(&json(r#", "calibration": {"yaw": 1}"#))
        .unwrap_err()
        .to_string();
    assert!(err.contains("yaw"), "{err}");
}
