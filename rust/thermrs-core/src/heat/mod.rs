//! The lumped thermal model of the robot's links: how hot each region the IR camera sees gets
//! for a motion duty ([`node`]), calibrated to the paper's KR 15/2 runs, Table 4
//! ([`calibration`]); and the first-order lag of the structure behind that surface temperature,
//! SPEC §6 effect `thermal_lag` ([`lag`]).

pub mod calibration;
pub mod lag;
pub mod node;

pub use calibration::{
    kr15_paper_nodes, saturating_through, solve_saturating_s0, KR15_PAPER_AMBIENT_C,
};
pub use lag::{first_order_lag, lag_step};
pub use node::{simulate, NodeParams, Rise};

use crate::error::KeyError;

/// Why a node, a series or a calibration is not usable. `Display` is one line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HeatError {
    /// A node without a name.
    #[error("thermal node: name is empty")]
    EmptyName,
    /// A node parameter out of range: which node, which key (as a scenario file spells it).
    #[error("thermal node {node:?}: {} {}", error.key, error.message)]
    Node { node: String, error: KeyError },
    /// Series that do not fit: unequal lengths, a non-finite value, a speed outside [0, 1].
    #[error("{context}: {message}")]
    Series { context: String, message: String },
    /// No saturating rise through the given points.
    #[error("saturating rise: {0}")]
    Saturating(String),
}

#[cfg(test)]
mod tests;
