//! `fri-ctl`: the operator's command-line client of the FRI service and the offline tools.
//!
//! Command groups are siblings under the top level: the running service's commands (over its
//! operator socket, see [`service`]) and `offline …` (payload estimation and pose design on
//! recorded files, without a robot, see [`offline`]). It depends on `fri-api` for everything it
//! exchanges with the daemon, never on the daemon itself.

pub mod offline;
pub mod service;
