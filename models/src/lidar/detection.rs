//! Detection and ranging: received waveform, noise, threshold, echoes (being written).

use serde::{Deserialize, Serialize};

use crate::effects::EffectInfo;

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[];

/// Receiver and detector parameters.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorConfig {}
