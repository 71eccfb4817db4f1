//! Simulated KUKA KRC2lr controller speaking FRI 1.x, with LWR 4+ physics.
//!
//! The crate is the robot for every test, benchmark and demo: it behaves like the real
//! controller on the wire (916-byte measurements, 376-byte commands, statistics, quality,
//! OFF/MON/CMD, the KRL handshake of the project contracts) and like the real arm in physics
//! (payload, motor-side friction, sensor noise/offset/drift/quantisation, a perturbed controller
//! model without the payload, contacts). It can also play a recorded log as the controller
//! ([`replay`], monitor mode only). See docs/mock-robot.md.

pub mod arm_profile;
pub mod config;
pub mod contact;
pub mod control;
pub mod controller;
pub mod error;
pub mod faults;
pub mod friction;
mod joints;
pub mod krl;
mod link;
pub mod models;
pub mod motion;
pub mod replay;
mod report;
pub mod sensors;
pub mod server;
pub mod simulation;
pub mod stats;
pub mod testkit;
pub mod truth;

pub use config::SimulationConfig;
pub use controller::{Controller, ControllerEvent, EventKind};
pub use error::SimError;
pub use replay::Replay;
pub use server::{
    AnswerCounts, MockRobotHandle, RunSummary, ServerConfig, TimingMode, spawn, spawn_new,
};
pub use simulation::{ContactState, ReceiveCounters, Simulation};
