//! Physics-based pulsed time-of-flight LiDAR (DIVP decomposition): scan model → signal propagation
//! → detection & ranging → point cloud → recognition.
//!
//! * [`scan`]: scan patterns (Velodyne VLS-128 / VLP-16 presets, generic spinning / MEMS / flash),
//!   per-firing timestamps.
//! * [`beam`]: beam footprint sampled by weighted sub-rays.
//! * [`signal`]: received power from the LiDAR equation, overlap function, solar background.
//! * [`detection`]: received waveform, APD/TIA noise, threshold detection, multi-echo, range walk,
//!   intensity mapping, saturation.

pub mod beam;
pub mod detection;
pub mod scan;
pub mod signal;

use serde::{Deserialize, Serialize};

use crate::effects::EffectInfo;

/// LiDAR-specific configuration (`"lidar"` key of the sensor configuration JSON).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LidarConfig {
    /// Receiver / detector parameters.
    #[serde(default)]
    pub detector: detection::DetectorConfig,
    /// Recognition (clustering, boxes, tracking) parameters.
    #[serde(default)]
    pub recognition: crate::recognition::lidar::LidarRecognitionConfig,
}

/// Every effect of the LiDAR model.
pub fn effects() -> Vec<EffectInfo> {
    [
        signal::EFFECTS,
        detection::EFFECTS,
        scan::EFFECTS,
        beam::EFFECTS,
    ]
    .concat()
}

/// The physical lidar model of a configuration (`mode: physical`).
pub fn build(
    config: crate::sensor::SensorConfig,
) -> Result<Box<dyn crate::sensor::SensorModel>, crate::sensor::ModelError> {
    Err(crate::sensor::ModelError::NotAvailable(format!(
        "the physical {} model is being written; use mode `ideal`",
        config.kind.name()
    )))
}
