//! `fri-service`: the on-robot daemon and operator interface for the KUKA LWR 4+ over FRI 1.x.
//!
//! Wiring of the library crates into one service: configuration, the operator socket protocol
//! and server, persistence of the applied payload / tare / calibration, the recording directory, jerk-limited commanded
//! moves, iceoryx2 publication, the 1 kHz loop hook and the operator workflows.

pub mod bounds;
pub mod config;
pub mod ctl;
pub mod demo;
pub mod ipc;
pub mod motion;
pub mod offline;
pub mod operator;
pub mod persistence;
pub mod recordings;
pub mod service;
pub mod stdio;
