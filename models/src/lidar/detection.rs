//! Detection and ranging: received waveform, noise, threshold, echoes (being written).
//!
//! API contract (used by the LiDAR sensor): one [`Detector`] per model instance, built once;
//! [`Detector::detect`] is called once per pulse (or per surface group) from many threads.

use rand::rngs::SmallRng;
use serde::{Deserialize, Serialize};

use crate::effects::{EffectInfo, Effects};
use crate::sensor::ModelError;

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[];

/// Receiver and detector parameters.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorConfig {}

/// Optical power reaching the detector from one surface contribution of one pulse (one sub-ray
/// hit), after the LiDAR equation, optics efficiency, overlap and two-way extinction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Return {
    /// Range of the contribution (half the two-way path length), m.
    pub range_m: f64,
    /// Peak optical power at the detector, W.
    pub power_w: f64,
    /// Ground-truth object (`osiris_proto::INVALID_ID` = none).
    pub object_id: u64,
}

/// One detected echo of a pulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Echo {
    /// Measured range, m.
    pub range_m: f64,
    /// Detected peak optical power (before saturation), W.
    pub peak_power_w: f64,
    /// Intensity on the configured scale (percent 0–100 or 0–255).
    pub intensity: f32,
    /// Signal-to-noise ratio of the peak (amplitude ratio, linear).
    pub snr: f32,
    /// The receiver saturated on this echo.
    pub saturated: bool,
    /// Echo pulse width at the threshold, s.
    pub pulse_width_s: f32,
    /// Ground-truth object contributing most power to the echo.
    pub object_id: u64,
}

/// Calibration curve of the intensity mapping: the peak power a 100 % Lambertian target at normal
/// incidence in clear air returns at each range (the sensor's range-dependent calibration).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IntensityCalibration {
    /// Ranges, m, ascending.
    pub range_m: Vec<f64>,
    /// Reference peak power at each range, W.
    pub reference_power_w: Vec<f64>,
}

/// The detection and ranging stage, planned once.
#[derive(Debug, Clone)]
pub struct Detector {}

impl Detector {
    /// Plan the detector for a configuration, the effect switches and the intensity calibration.
    pub fn new(
        _config: &DetectorConfig,
        _effects: &Effects,
        _calibration: IntensityCalibration,
    ) -> Result<Detector, ModelError> {
        Ok(Detector {})
    }

    /// Detect the echoes of one pulse from its returns (any order; may be reordered), with the
    /// optical background power `background_w` (W, at the detector) and noise from `rng`. Echoes are
    /// appended to `out` in the order of the configured return mode.
    pub fn detect(
        &self,
        _returns: &mut [Return],
        _background_w: f64,
        _rng: &mut SmallRng,
        _out: &mut Vec<Echo>,
    ) {
    }
}
