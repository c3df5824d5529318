//! One file per solver.

#[cfg(feature = "clarabel")]
pub mod clarabel;
#[cfg(feature = "good_lp")]
pub mod good_lp;
pub mod native;
#[cfg(feature = "osqp")]
pub mod osqp;
