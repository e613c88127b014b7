//! Camera recognition: objects from the rendered view. For each ground-truth object the visible
//! pixel fraction (occlusion from the render), its contrast against the background and its size in
//! pixels give a detection probability; a detected object gets a 2D box from its visible pixels, a
//! class, a distance from the box and the camera height → OSI `DetectedMovingObject` plus the DIVP
//! camera recognition fields ([`perception::CameraObject`]).
//!
//! (Contract stub: the recognition helper replaces the body; the signatures are fixed.)

use osiris_proto::{osi3, perception};
use serde::{Deserialize, Serialize};

use crate::camera::RenderAux;
use crate::camera::lens::Lens;
use crate::frames::SensorFrame;
use crate::sensor::ModelError;

/// Camera recognition parameters (`"recognition"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraRecognitionConfig {}

impl CameraRecognitionConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        Ok(())
    }
}

/// What recognition sees of one frame.
pub struct CameraRecognitionInput<'a> {
    /// Per-pixel object ids and depths of the render.
    pub aux: &'a RenderAux,
    /// Linear relative luminance per pixel (ISP, before tone mapping), row-major.
    pub luminance: &'a [f32],
    pub lens: &'a Lens,
    /// The SensorView's ground truth (object classes and sizes; never their positions).
    pub ground_truth: &'a osi3::GroundTruth,
    /// The sensor frame in global coordinates (for the OSI output in the host frame).
    pub frame: &'a SensorFrame,
    /// Mounting of the sensor on the host (sensor frame relative to the host vehicle frame).
    pub mounting: &'a osi3::MountingPosition,
    /// Height of the camera's optical centre above the road, m.
    pub camera_height_m: f64,
    pub time_s: f64,
    pub seed: u64,
    pub cycle: u64,
}

/// Camera recognition (keeps track state across frames).
pub struct CameraRecognition {
    config: CameraRecognitionConfig,
}

impl CameraRecognition {
    pub fn new(config: &CameraRecognitionConfig) -> Result<CameraRecognition, ModelError> {
        config.validate()?;
        Ok(CameraRecognition {
            config: config.clone(),
        })
    }

    /// Recognise the objects of one frame: OSI objects (host-vehicle frame, as OSI SensorData's
    /// `moving_object`) and the DIVP fields (sensor frame).
    pub fn step(
        &mut self,
        input: &CameraRecognitionInput<'_>,
        objects: &mut Vec<osi3::DetectedMovingObject>,
        divp: &mut Vec<perception::CameraObject>,
    ) {
        let _ = (&self.config, input);
        objects.clear();
        divp.clear();
    }

    pub fn reset(&mut self) {}
}
