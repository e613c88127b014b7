//! Physics-based 76–81 GHz FMCW radar (DIVP decomposition): ray-traced paths → baseband signal
//! generation → range/velocity FFTs → threshold processing → direction estimation → peaks →
//! recognition.
//!
//! * [`propagation`]: paths from the space-design layer → [`PathReturn`]s (radar equation,
//!   physical-optics scattering, Fresnel reflection, ground multipath, attenuation).
//! * [`antenna`]: Tx/Rx antenna gain patterns (table or parametric).
//! * [`waveform`]: chirp sequence and MIMO array (virtual array) parameters and derived quantities.
//! * [`baseband`]: IF cube synthesis (samples × chirps × virtual channels) with noise and
//!   impairments.
//! * [`processing`]: windowed range / Doppler FFTs, CFAR, peak interpolation, angle estimation.

pub mod antenna;
pub mod baseband;
pub mod processing;
pub mod propagation;
pub mod waveform;

use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::effects::EffectInfo;

/// One propagation path as the baseband sees it: what reaches the receiver from one scattering
/// contribution, for the whole frame (stop-and-hop: range and direction are those at the frame's
/// reference time; the range rate gives the phase progression).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathReturn {
    /// Half the total path length Tx → … → Rx (the range the radar measures), m.
    pub range_m: f64,
    /// Rate of `range_m`, m/s, positive when the path gets longer (target receding).
    pub range_rate_m_s: f64,
    /// Direction of departure at the Tx array, sensor frame: azimuth (about +z from +x), rad.
    pub tx_azimuth_rad: f64,
    /// Direction of departure at the Tx array: elevation (positive up), rad.
    pub tx_elevation_rad: f64,
    /// Direction of arrival at the Rx array: azimuth, rad.
    pub rx_azimuth_rad: f64,
    /// Direction of arrival at the Rx array: elevation, rad.
    pub rx_elevation_rad: f64,
    /// Complex amplitude at the receiver input, √W (|a|² = received power incl. antenna gains,
    /// spreading, scattering, reflection coefficients, attenuation; arg a = propagation phase
    /// beyond the 4πR/λ the baseband adds itself, e.g. the reflection coefficients' phases).
    pub amplitude: Complex64,
    /// Ground-truth object the path scattered off last (`osiris_proto::INVALID_ID` = static world).
    pub object_id: u64,
}

/// Radar-specific configuration (`"radar"` key of the sensor configuration JSON).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadarConfig {
    /// Chirp sequence.
    #[serde(default)]
    pub waveform: waveform::WaveformConfig,
    /// Tx / Rx antenna layout (MIMO).
    #[serde(default)]
    pub array: waveform::ArrayConfig,
    /// Transmit power, antenna patterns, noise figure.
    #[serde(default)]
    pub front_end: antenna::FrontEndConfig,
    /// FFT windows, CFAR, angle estimation.
    #[serde(default)]
    pub processing: processing::ProcessingConfig,
    /// Recognition (clustering, ghost rejection, tracking) parameters.
    #[serde(default)]
    pub recognition: crate::recognition::radar::RadarRecognitionConfig,
}

/// Every effect of the radar model.
pub fn effects() -> Vec<EffectInfo> {
    [propagation::EFFECTS, antenna::EFFECTS, baseband::EFFECTS].concat()
}

/// The physical radar model of a configuration (`mode: physical`).
pub fn build(
    config: crate::sensor::SensorConfig,
) -> Result<Box<dyn crate::sensor::SensorModel>, crate::sensor::ModelError> {
    Err(crate::sensor::ModelError::NotAvailable(format!(
        "the physical {} model is being written; use mode `ideal`",
        config.kind.name()
    )))
}
