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
