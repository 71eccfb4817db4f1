//! The demo (`fri-service demo`) and the simulated-controller driver it shares with the
//! end-to-end tests.

pub mod driver;
pub mod plots;
pub mod run;
