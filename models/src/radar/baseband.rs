//! (being written)

use crate::effects::EffectInfo;

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[];
