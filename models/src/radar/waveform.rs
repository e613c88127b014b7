//! Chirp sequence and MIMO array (being written).

use serde::{Deserialize, Serialize};

/// FMCW chirp sequence parameters.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaveformConfig {}

/// Tx / Rx antenna layout.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArrayConfig {}
