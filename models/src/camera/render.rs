//! Spectral ray-traced rendering of the scene radiance seen by each pixel.
//!
//! (Contract stub: the rendering helper replaces the body; the signatures are fixed.)

use glam::{DVec3, Vec3};
use osiris_proto::osi3;
use serde::{Deserialize, Serialize};

use super::{
    CHANNELS, ChannelImage, Flicker, RenderAux, ShutterTiming, SpectralBands, SpectralResponse,
};
use crate::effects::{EffectInfo, Effects};
use crate::sensor::ModelError;
use crate::world::WorldFrame;

/// Rolling shutter: row r is exposed from `r · row_time_s` after row 0, and the renderer traces it
/// from the sensor pose (and object poses) of that time.
pub const ROLLING_SHUTTER: EffectInfo = EffectInfo {
    name: "camera.rolling_shutter",
    default_on: true,
    summary: "stub",
    source: "stub",
};

/// Render effects (`camera.rolling_shutter`, `camera.motion_blur`, ...).
pub const EFFECTS: &[EffectInfo] = &[ROLLING_SHUTTER];

/// Rendering parameters (`"render"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderConfig {}

impl RenderConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        Ok(())
    }
}

/// What one render needs.
pub struct RenderInput<'a> {
    pub frame: &'a WorldFrame<'a>,
    /// Primary-ray directions in the sensor frame (x forward, y left, z up), unit, one per pixel,
    /// row-major (from [`super::lens::Lens::ray_directions`]).
    pub rays: &'a [Vec3],
    pub width: usize,
    pub height: usize,
    pub response: &'a SpectralResponse,
    pub timing: ShutterTiming,
    /// The SensorView's ground truth (sun, time of day, vehicle light states).
    pub ground_truth: &'a osi3::GroundTruth,
    pub seed: u64,
    pub cycle: u64,
}

/// The sun when it is in front of the camera (for lens flare).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunInView {
    /// Unit vector towards the sun in the sensor frame.
    pub direction_sensor: DVec3,
    /// Photo-electron radiance of the solar disk per channel, e⁻ s⁻¹ m⁻² sr⁻¹.
    pub radiance: [f64; CHANNELS],
    /// Solid angle of the disk, sr.
    pub solid_angle_sr: f64,
}

/// Cost split of one render, s of wall-clock time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RenderStats {
    pub rays: u64,
    pub trace_s: f64,
    pub shading_s: f64,
}

/// What one render produces.
#[derive(Debug, Clone, Default)]
pub struct RenderOutput {
    /// Photo-electron radiance per channel, e⁻ s⁻¹ m⁻² sr⁻¹.
    pub radiance: ChannelImage,
    pub aux: RenderAux,
    /// Pixels seeing LED sources directly (only with `camera.led_flicker` on).
    pub flicker: Flicker,
    pub sun: Option<SunInView>,
    pub stats: RenderStats,
}

/// The spectral renderer (plan once: band tables, light spectra; execute per frame).
pub struct Renderer {
    bands: SpectralBands,
}

impl Renderer {
    pub fn new(config: &RenderConfig, effects: &Effects) -> Result<Renderer, ModelError> {
        let _ = (config, effects);
        Ok(Renderer {
            bands: SpectralBands::uniform(380.0, 780.0, 16),
        })
    }

    pub fn bands(&self) -> &SpectralBands {
        &self.bands
    }

    pub fn render(&mut self, input: &RenderInput<'_>, out: &mut RenderOutput) {
        out.radiance.resize(input.width, input.height);
        out.aux.object_index.clear();
        out.aux
            .object_index
            .resize(input.width * input.height, super::NO_OBJECT);
        out.aux.depth_m.clear();
        out.aux
            .depth_m
            .resize(input.width * input.height, f32::INFINITY);
        out.aux.object_ids.clear();
        out.flicker.clear();
        out.sun = None;
    }
}
