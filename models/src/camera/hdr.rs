//! Multi-exposure / split-pixel HDR: capture sequence, merge to linear 20–24 bit, PWL companding.
//!
//! (Contract stub: the pixel helper replaces the body; the signatures are fixed.)

use serde::{Deserialize, Serialize};

use super::RawImage;
use super::pixel::{ExposureSpec, PixelModel};
use crate::effects::{EffectInfo, Effects};
use crate::sensor::ModelError;

/// HDR effects (`camera.hdr_companding`).
pub const EFFECTS: &[EffectInfo] = &[];

/// HDR parameters (`"hdr"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HdrConfig {}

impl HdrConfig {
    /// The defaults of a sensor preset.
    pub fn for_preset(preset: super::CameraPreset) -> HdrConfig {
        let _ = preset;
        HdrConfig::default()
    }

    pub fn validate(&self) -> Result<(), ModelError> {
        Ok(())
    }
}

/// A PWL knee: linear input DN → companded output DN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knee {
    pub input_dn: f64,
    pub output_dn: f64,
}

/// The planned HDR pipeline.
pub struct HdrPipeline {
    knees: Vec<Knee>,
}

impl HdrPipeline {
    pub fn new(config: &HdrConfig, effects: &Effects) -> Result<HdrPipeline, ModelError> {
        let _ = (config, effects);
        Ok(HdrPipeline { knees: Vec::new() })
    }

    /// The captures of one frame, most sensitive first, for a base (longest) exposure time.
    pub fn captures(&self, pixel: &PixelModel, base_exposure_s: f64) -> Vec<ExposureSpec> {
        vec![pixel.base_exposure(base_exposure_s)]
    }

    /// Merge the captures (same order as [`Self::captures`]) into one linear RAW on the scale of
    /// the first capture (DN of capture 0, extended above its saturation), `out.bit_depth` 20–24.
    pub fn merge(&self, captures: &[RawImage], out: &mut RawImage) {
        if let Some(c) = captures.first() {
            out.clone_from(c);
        }
    }

    /// PWL-compand a linear RAW (the knees are [`Self::knees`]); identity when
    /// `camera.hdr_companding` is off.
    pub fn compand(&self, linear: &RawImage, out: &mut RawImage) {
        out.clone_from(linear);
    }

    /// Invert the companding (decompanding LUT), for tools reading companded RAW.
    pub fn decompand(&self, companded_dn: u32) -> f64 {
        f64::from(companded_dn)
    }

    pub fn knees(&self) -> &[Knee] {
        &self.knees
    }
}
