//! Helpers shared by the osiris-models integration tests (`mod common;` in a test file). Each
//! test file uses a subset, hence `dead_code` is allowed here.
#![allow(dead_code)]

use std::f64::consts::PI;

use num_complex::Complex64;
use osiris_models::radar::PathReturn;
use osiris_proto::osi3;

/// OSI sun (azimuth counter-clockwise from north, the scene's +y; +x is east), rad.
pub fn sun(azimuth: f64, elevation: f64) -> osi3::EnvironmentalConditions {
    osi3::EnvironmentalConditions {
        sun: Some(osi3::environmental_conditions::Sun {
            azimuth: Some(azimuth),
            elevation: Some(elevation),
            intensity: None,
        }),
        ..Default::default()
    }
}

/// A power ratio in dB.
pub fn db(x: f64) -> f64 {
    10.0 * x.log10()
}

/// Total received power of the coherent sum of the radar paths of objects (the baseband phase
/// e^{j2kR} included), W. Paths of no object (`INVALID_ID`: the road clutter of
/// `radar.road_clutter`) are left out: the tests that use this measure targets.
pub fn coherent_power_w(paths: &[PathReturn], lambda: f64) -> f64 {
    let k = 2.0 * PI / lambda;
    paths
        .iter()
        .filter(|p| p.object_id != osiris_proto::INVALID_ID)
        .map(|p| p.amplitude * Complex64::from_polar(1.0, 2.0 * k * p.range_m))
        .sum::<Complex64>()
        .norm_sqr()
}

// ---------------------------------------------------------------------------------------------
// OSI builders

/// OSI vector from `[x, y, z]` (or a `DVec3`), m or m/s.
pub fn v3(a: impl Into<[f64; 3]>) -> osi3::Vector3d {
    let [x, y, z] = a.into();
    osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    }
}

/// OSI box dimension from `[length, width, height]`, m.
pub fn dim(d: impl Into<[f64; 3]>) -> osi3::Dimension3d {
    let [length, width, height] = d.into();
    osi3::Dimension3d {
        length: Some(length),
        width: Some(width),
        height: Some(height),
    }
}

/// OSI orientation from roll, pitch, yaw, rad.
pub fn rpy(roll: f64, pitch: f64, yaw: f64) -> osi3::Orientation3d {
    osi3::Orientation3d {
        roll: Some(roll),
        pitch: Some(pitch),
        yaw: Some(yaw),
    }
}

/// A moving object of `model_reference` `reference` (OSI type OTHER) with id `oid`, its box centre
/// at `pos` (m), yaw (rad), box `dim` (length, width, height, m), velocity `vel` (m/s), no rotation.
pub fn moving_object(
    reference: &str,
    oid: u64,
    pos: [f64; 3],
    yaw: f64,
    dim: [f64; 3],
    vel: [f64; 3],
) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(osiris_proto::id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(self::dim(dim)),
            position: Some(v3(pos)),
            orientation: Some(rpy(0.0, 0.0, yaw)),
            velocity: Some(v3(vel)),
            orientation_rate: Some(rpy(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Other as i32),
        model_reference: Some(reference.into()),
        ..Default::default()
    }
}

// ---------------------------------------------------------------------------------------------
// Radar chain

/// A monostatic point path at `range_m`, range rate `v_m_s`, azimuth / elevation (deg) and
/// received power `dbm` (at the receiver input), object id `id`.
pub fn point_path(
    range_m: f64,
    v_m_s: f64,
    az_deg: f64,
    el_deg: f64,
    dbm: f64,
    id: u64,
) -> PathReturn {
    let (az, el) = (az_deg.to_radians(), el_deg.to_radians());
    PathReturn {
        range_m,
        range_rate_m_s: v_m_s,
        tx_azimuth_rad: az,
        tx_elevation_rad: el,
        rx_azimuth_rad: az,
        rx_elevation_rad: el,
        amplitude: Complex64::new((1e-3 * 10f64.powf(dbm / 10.0)).sqrt(), 0.0),
        object_id: id,
    }
}

/// One frame of the chain over `paths` with noise seed `seed`.
pub fn run_chain(
    chain: &mut osiris_models::radar::baseband::RadarChain,
    paths: &[PathReturn],
    seed: u64,
) -> Vec<osiris_models::radar::baseband::ChainDetection> {
    let mut out = Vec::new();
    chain.run(paths, seed, &mut out);
    out
}

// ---------------------------------------------------------------------------------------------
// LiDAR

/// One step of a fresh LiDAR model of `cfg` on `view` at t = 1 s (step 0.1 s): the output and the
/// model.
pub fn lidar_step(
    cfg: osiris_models::SensorConfig,
    view: &osi3::SensorView,
) -> (osiris_models::StepOutput, osiris_models::lidar::LidarSensor) {
    use osiris_models::SensorModel;
    let mut s = osiris_models::lidar::LidarSensor::new(cfg).expect("valid config");
    let mut out = osiris_models::StepOutput::default();
    s.step(
        &osiris_models::StepInput {
            view,
            time_s: 1.0,
            step_s: 0.1,
        },
        &mut out,
    )
    .expect("step");
    (out, s)
}

/// One step of `sensor` on `view` at `time_s` (communication step `step_s`).
pub fn step_at(
    sensor: &mut dyn osiris_models::SensorModel,
    view: &osi3::SensorView,
    time_s: f64,
    step_s: f64,
) -> osiris_models::StepOutput {
    let mut out = osiris_models::StepOutput::default();
    sensor
        .step(
            &osiris_models::StepInput {
                view,
                time_s,
                step_s,
            },
            &mut out,
        )
        .expect("step");
    out
}

/// Every radar detection of a step's SensorData.
pub fn radar_detections(out: &osiris_models::StepOutput) -> Vec<osi3::RadarDetection> {
    out.sensor_data
        .feature_data
        .as_ref()
        .map(|f| {
            f.radar_sensor
                .iter()
                .flat_map(|s| s.detection.clone())
                .collect()
        })
        .unwrap_or_default()
}

/// A SensorView at t = 0 whose ground truth holds only `objects` (no host, no lanes: the radar
/// tests' scenes on the documented fallback ground plane).
pub fn view_of(objects: Vec<osi3::MovingObject>) -> osi3::SensorView {
    osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(osiris_proto::timestamp_from_seconds(0.0)),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(osiris_proto::timestamp_from_seconds(0.0)),
            moving_object: objects,
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// LiDAR effects off that make the received power deterministic (no noise, no saturation, no
/// sun, no dropped rays).
pub fn quiet_lidar() -> osiris_models::effects::EffectSwitches {
    [
        ("lidar.detector_noise", false),
        ("lidar.detector_saturation", false),
        ("lidar.solar_background", false),
        ("lidar.dropped_rays", false),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v))
    .collect()
}
