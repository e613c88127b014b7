//! (being written)

use serde::{Deserialize, Serialize};

/// LiDAR recognition parameters.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LidarRecognitionConfig {}
