//! Chirp sequence and MIMO array (being written).

use serde::{Deserialize, Serialize};

/// FMCW chirp sequence parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WaveformConfig {
    /// Carrier (start) frequency of the chirps, Hz.
    pub carrier_frequency_hz: f64,
}

impl Default for WaveformConfig {
    fn default() -> Self {
        WaveformConfig {
            carrier_frequency_hz: 76.5e9,
        }
    }
}

impl WaveformConfig {
    /// Wavelength at the centre of the swept band, m.
    pub fn wavelength_m(&self) -> f64 {
        299_792_458.0 / self.carrier_frequency_hz
    }
}

/// Tx / Rx antenna layout.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArrayConfig {}
