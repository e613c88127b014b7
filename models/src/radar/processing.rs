//! Range / Doppler FFTs, CFAR, angle estimation (being written).

use serde::{Deserialize, Serialize};

/// Signal-processing parameters.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProcessingConfig {}
