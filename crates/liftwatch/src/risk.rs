//! (in progress)

use serde::{Deserialize, Serialize};

/// Risk settings (in progress).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RiskConfig {}
