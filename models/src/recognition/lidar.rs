//! LiDAR recognition (being written).

use osiris_proto::osi3;
use serde::{Deserialize, Serialize};

use super::{EgoState, LidarPoint};
use crate::sensor::ModelError;

/// LiDAR recognition parameters.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LidarRecognitionConfig {}

/// LiDAR object recognition with tracking (state kept across steps).
#[derive(Debug, Clone)]
pub struct LidarRecognition {}

impl LidarRecognition {
    pub fn new(_config: &LidarRecognitionConfig) -> Result<LidarRecognition, ModelError> {
        Ok(LidarRecognition {})
    }

    /// One cycle: `points` in the sensor frame → detected moving objects (sensor frame) appended to
    /// `out`.
    pub fn step(
        &mut self,
        _ego: &EgoState,
        _points: &[LidarPoint],
        _out: &mut Vec<osi3::DetectedMovingObject>,
    ) {
    }

    /// Forget all tracks.
    pub fn reset(&mut self) {}
}
