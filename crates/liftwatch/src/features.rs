//! Stage 3: physical features from aligned samples (paper, Sec. 4.1).
//!
//! ```text
//! v   = direction · speed                     signed velocity (m/s, + up)
//! λ   = L_ref / 100                           static load ratio, L_ref held from door close
//! a_v = smoothed Δv/Δt                        speed path
//! a_L = g·(L − L_ref)/100 / (λ + p)           load-cell inertial path, p fitted on history
//! a   = β·a_v + (1 − β)·a_L                   β high while starting/braking, low while cruising
//! ```
//!
//! (interface fixed here; implementation in progress)

use serde::{Deserialize, Serialize};

/// Settings of feature extraction; saved in the model file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureConfig {
    /// Rated load M_r (kg), to turn the load percentage into λ.
    pub rated_load_kg: f64,
    /// |v| above which the car counts as moving (m/s).
    pub moving_threshold_mps: f64,
    /// p of the load-cell path: platform and sling mass felt by the cell, as a fraction of M_r.
    pub load_cell_platform_ratio: f64,
    /// β while starting or braking (speed path weight).
    pub beta_transient: f64,
    /// β while cruising or at rest.
    pub beta_cruise: f64,
}

/// Phase of travel of one sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// Not moving.
    Standstill,
    /// Speeding up.
    Accelerating,
    /// Near constant speed.
    Cruising,
    /// Slowing down.
    Decelerating,
}

/// Features of one aligned sample. `NaN` marks a value that cannot be computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureRow {
    /// Time (s).
    pub time: f64,
    /// v: signed car velocity (m/s, + up).
    pub v: f64,
    /// s: direction of motion, +1 up, −1 down, 0 at rest (|v| below the threshold).
    pub s: i8,
    /// λ: static load ratio (0..1 of rated load), held from the last door close.
    pub lambda: f64,
    /// a_v: acceleration from the speed path (m/s²).
    pub a_v: f64,
    /// a_L: acceleration from the load-cell path (m/s²), NaN while not applicable.
    pub a_l: f64,
    /// a: fused acceleration (m/s²).
    pub a: f64,
    /// U: measured motor voltage (V).
    pub voltage: f64,
    /// Phase of travel.
    pub phase: Phase,
    /// Index of the trip this sample belongs to, if moving.
    pub trip: Option<u32>,
}
