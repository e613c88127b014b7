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

/// Total received power of the coherent sum of radar paths (the baseband phase e^{j2kR}
/// included), W.
pub fn coherent_power_w(paths: &[PathReturn], lambda: f64) -> f64 {
    let k = 2.0 * PI / lambda;
    paths
        .iter()
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
