//! The console, from both ends: the simulated block behind the board's console, and the
//! researcher's client that drives either.
//!
//! - [`sim`]: `host-sim console`, the block behind the board's console (stdin or a pty).
//! - [`desk`]: `thermorph-desk`, the researcher's desk: console, recorder, scripts, plots.

pub mod desk;
pub mod sim;
