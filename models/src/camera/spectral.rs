//! Spectral bands and the colour-filter × quantum-efficiency response of the pixels.
//!
//! (Contract stub: the spectral helper replaces the body; the signatures are fixed.)

use serde::{Deserialize, Serialize};

use super::CHANNELS;
use crate::sensor::ModelError;

/// Wavelength bands the scene is rendered in: `centres_nm[k] ± width_nm/2`.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralBands {
    pub centres_nm: Vec<f64>,
    pub width_nm: f64,
}

impl SpectralBands {
    /// `n` equal bands covering `[start_nm, end_nm]`.
    pub fn uniform(start_nm: f64, end_nm: f64, n: usize) -> SpectralBands {
        let n = n.max(1);
        let width_nm = (end_nm - start_nm) / n as f64;
        SpectralBands {
            centres_nm: (0..n)
                .map(|k| start_nm + (k as f64 + 0.5) * width_nm)
                .collect(),
            width_nm,
        }
    }

    pub fn len(&self) -> usize {
        self.centres_nm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.centres_nm.is_empty()
    }
}

/// Per channel and band: photo-electrons per joule of spectral radiance in the band,
/// `w_c(λ_k) = QE(λ_k) · CFA_c(λ_k) · T_IR(λ_k) · λ_k / (h c) · Δλ` [e⁻ nm J⁻¹], so that the
/// photo-electron radiance is `L_c = Σ_k L_λ(λ_k) · w_c(λ_k)` with `L_λ` in W m⁻² sr⁻¹ nm⁻¹.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralResponse {
    pub bands: SpectralBands,
    pub weights: [Vec<f64>; CHANNELS],
}

impl SpectralResponse {
    /// `L_c` of a spectrum sampled at the band centres (W m⁻² sr⁻¹ nm⁻¹ → e⁻ s⁻¹ m⁻² sr⁻¹).
    pub fn apply(&self, spectrum: &[f64]) -> [f64; CHANNELS] {
        let mut out = [0.0; CHANNELS];
        for (c, o) in out.iter_mut().enumerate() {
            *o = self.weights[c]
                .iter()
                .zip(spectrum)
                .map(|(w, s)| w * s)
                .sum();
        }
        out
    }
}

/// Colour filters, quantum efficiency and IR-cut filter (`"spectral"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpectralConfig {}

impl SpectralConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        Ok(())
    }

    /// The response of the configured sensor sampled on `bands`.
    pub fn response(&self, bands: &SpectralBands) -> Result<SpectralResponse, ModelError> {
        // Stub: flat QE 0.5 for every channel.
        const HC: f64 = 6.626_070_15e-34 * 299_792_458.0;
        let w: Vec<f64> = bands
            .centres_nm
            .iter()
            .map(|l| 0.5 * l * 1e-9 / HC * bands.width_nm / 3.0)
            .collect();
        Ok(SpectralResponse {
            bands: bands.clone(),
            weights: [w.clone(), w.clone(), w],
        })
    }
}
