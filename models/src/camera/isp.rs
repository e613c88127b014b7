//! Image signal processor: black level, demosaic, white balance, colour correction to sRGB, tone
//! mapping, 8-bit sRGB output.
//!
//! (Contract stub: the ISP helper replaces the body; the signatures are fixed.)

use serde::{Deserialize, Serialize};

use super::{Cfa, RawImage, RgbImage, SpectralResponse};
use crate::effects::EffectInfo;
use crate::sensor::ModelError;

/// ISP stages are processing, not physics: none is an effect, but the list exists for symmetry.
pub const EFFECTS: &[EffectInfo] = &[];

/// ISP parameters (`"isp"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IspConfig {}

impl IspConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        Ok(())
    }
}

/// The ISP (keeps white-balance / tone state across frames).
pub struct Isp {
    cfa: Cfa,
}

impl Isp {
    /// Plan the ISP for a sensor: the colour-correction matrix is fitted to the sensor's
    /// spectral response.
    pub fn new(
        config: &IspConfig,
        cfa: Cfa,
        response: &SpectralResponse,
    ) -> Result<Isp, ModelError> {
        let _ = (config, response);
        Ok(Isp { cfa })
    }

    /// Process a linear (HDR-merged) RAW mosaic into 8-bit sRGB; also writes the linear relative
    /// luminance (Y of linear sRGB, white-balanced, before tone mapping) of every pixel.
    pub fn process(&mut self, raw: &RawImage, out: &mut RgbImage, luminance: &mut Vec<f32>) {
        let _ = self.cfa;
        out.width = raw.width;
        out.height = raw.height;
        out.data.clear();
        out.data.resize(raw.width * raw.height * 3, 0);
        luminance.clear();
        luminance.extend(raw.data.iter().map(|&v| v as f32));
    }

    pub fn reset(&mut self) {}
}
