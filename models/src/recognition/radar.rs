//! Radar recognition (being written).

use osiris_proto::osi3;
use serde::{Deserialize, Serialize};

use super::{EgoState, RadarDetection};
use crate::sensor::ModelError;

/// Radar recognition parameters.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadarRecognitionConfig {}

/// Radar object recognition with tracking (state kept across steps).
#[derive(Debug, Clone)]
pub struct RadarRecognition {}

impl RadarRecognition {
    pub fn new(_config: &RadarRecognitionConfig) -> Result<RadarRecognition, ModelError> {
        Ok(RadarRecognition {})
    }

    /// One cycle: `detections` (sensor frame) → detected moving objects (sensor frame) appended
    /// to `out`.
    pub fn step(
        &mut self,
        _ego: &EgoState,
        _detections: &[RadarDetection],
        _out: &mut Vec<osi3::DetectedMovingObject>,
    ) {
    }

    /// Forget all tracks.
    pub fn reset(&mut self) {}
}
