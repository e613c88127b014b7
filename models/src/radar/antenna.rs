//! Antenna gain patterns and the RF front end (being written).

use serde::{Deserialize, Serialize};

use crate::effects::EffectInfo;

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[];

/// Transmit power, antenna patterns, receiver noise figure.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrontEndConfig {}
