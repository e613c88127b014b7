//! EMVA 1288 pixel model: photo-electrons → digital numbers with shot noise, dark current, read
//! noise, DSNU, PRNU, full well, conversion gain, ADC; LED flicker; auto exposure.
//!
//! (Contract stub: the pixel helper replaces the body; the signatures are fixed.)

use serde::{Deserialize, Serialize};

use super::{Cfa, ChannelImage, Flicker, RawImage, ShutterTiming};
use crate::effects::{EffectInfo, Effects};
use crate::sensor::ModelError;

/// Pixel effects (`camera.shot_noise`, `camera.read_noise`, `camera.dark_current`, `camera.dsnu`,
/// `camera.prnu`, `camera.saturation`, `camera.led_flicker`).
pub const EFFECTS: &[EffectInfo] = &[];

/// Pixel parameters (`"pixel"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PixelConfig {}

impl PixelConfig {
    /// The defaults of a sensor preset.
    pub fn for_preset(preset: super::CameraPreset) -> PixelConfig {
        let _ = preset;
        PixelConfig::default()
    }

    pub fn validate(&self) -> Result<(), ModelError> {
        Ok(())
    }

    /// Rolling-shutter line time, s, for an image of `height` rows read within `frame_cycle_s`
    /// (the configured line time if any).
    pub fn row_time_s(&self, height: usize, frame_cycle_s: f64) -> f64 {
        0.5 * frame_cycle_s / height.max(1) as f64
    }
}

/// One capture of the HDR sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExposureSpec {
    /// Exposure (integration) time, s.
    pub time_s: f64,
    /// Analog gain (linear) before the ADC.
    pub analog_gain: f64,
    /// Relative sensitivity of the photodiode used (1 = large PD; IMX490 small PD ≈ 0.1).
    pub relative_sensitivity: f64,
    /// Conversion gain of the readout, DN/e⁻ at unity analog gain.
    pub conversion_gain_dn_per_e: f64,
    /// Full-well capacity of the photodiode used, e⁻.
    pub full_well_e: f64,
    /// Read noise of this readout, e⁻ rms.
    pub read_noise_e: f64,
    /// Start of this capture relative to the row's start of the first capture, s.
    pub start_offset_s: f64,
    /// Index in the sequence (0 = the most sensitive).
    pub index: u32,
}

/// The planned pixel array (fixed-pattern maps drawn once from the seed).
pub struct PixelModel {
    width: usize,
    height: usize,
}

impl PixelModel {
    pub fn new(
        config: &PixelConfig,
        width: usize,
        height: usize,
        effects: &Effects,
        seed: u64,
    ) -> Result<PixelModel, ModelError> {
        let _ = (config, effects, seed);
        Ok(PixelModel { width, height })
    }

    /// CFA layout of the array.
    pub fn cfa(&self) -> Cfa {
        Cfa::Rggb
    }

    /// The single-exposure capture of the configuration (base of the HDR sequence).
    pub fn base_exposure(&self, time_s: f64) -> ExposureSpec {
        ExposureSpec {
            time_s,
            analog_gain: 1.0,
            relative_sensitivity: 1.0,
            conversion_gain_dn_per_e: 0.25,
            full_well_e: 10_000.0,
            read_noise_e: 2.0,
            start_offset_s: 0.0,
            index: 0,
        }
    }

    /// Exposure time an auto-exposure loop converges to for this rate image, s.
    pub fn auto_exposure_s(&self, rate: &ChannelImage) -> f64 {
        let _ = rate;
        0.01
    }

    /// Expose the array: `rate` in e⁻/s per pixel and channel (the pixel reads its CFA channel),
    /// flicker samples integrated per row over the capture's window.
    pub fn expose(
        &self,
        rate: &ChannelImage,
        flicker: &Flicker,
        exposure: &ExposureSpec,
        timing: &ShutterTiming,
        temperature_c: f64,
        noise_seed: u64,
        out: &mut RawImage,
    ) {
        let _ = (rate, flicker, timing, temperature_c, noise_seed);
        out.width = self.width;
        out.height = self.height;
        out.data.clear();
        out.data.resize(self.width * self.height, 0);
        out.bit_depth = 12;
        out.exposure_time_s = exposure.time_s;
        out.analog_gain = exposure.analog_gain;
        out.conversion_gain_dn_per_e = exposure.conversion_gain_dn_per_e * exposure.analog_gain;
        out.exposure_index = exposure.index;
    }
}
