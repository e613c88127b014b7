//! IF cube synthesis and the processing chain entry point (being written).
//!
//! API contract (used by the radar sensor): one [`RadarChain`] per model instance, planned once;
//! per frame [`RadarChain::run`] synthesises the IF cube from the paths and processes it into
//! detections.

use crate::effects::{EffectInfo, Effects};
use crate::sensor::ModelError;

use super::PathReturn;
use super::antenna::FrontEndConfig;
use super::processing::ProcessingConfig;
use super::waveform::{ArrayConfig, WaveformConfig};

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[];

/// One detection of the processing chain (sensor frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainDetection {
    /// Range, m (interpolated).
    pub range_m: f64,
    /// Range rate, m/s, positive away (interpolated).
    pub range_rate_m_s: f64,
    /// Azimuth, rad (about +z from +x).
    pub azimuth_rad: f64,
    /// Elevation, rad (positive up; 0 when the array has no vertical aperture).
    pub elevation_rad: f64,
    /// Received power of the peak referred to the receiver input, dBm.
    pub power_dbm: f64,
    /// Signal-to-noise ratio after processing, dB.
    pub snr_db: f64,
    /// Ground-truth object of the strongest path in the detected cell.
    pub object_id: u64,
}

/// The baseband synthesis and signal processing, planned once (FFT plans, buffers).
pub struct RadarChain {}

impl RadarChain {
    /// Plan the chain.
    pub fn new(
        _waveform: &WaveformConfig,
        _array: &ArrayConfig,
        _front_end: &FrontEndConfig,
        _processing: &ProcessingConfig,
        _effects: &Effects,
    ) -> Result<RadarChain, ModelError> {
        Ok(RadarChain {})
    }

    /// One frame: synthesise the IF cube from `paths` (plus noise and impairments, random state
    /// from `seed`), process it, and append the detections to `out`.
    pub fn run(&mut self, _paths: &[PathReturn], _seed: u64, _out: &mut Vec<ChainDetection>) {}
}
