//! Sensorless collision detection for the KUKA LWR 4+ with an estimated payload
//! (Gaz & De Luca, IROS 2017, Sec. VI-B, eq. 48).
//!
//! This increment holds the model-independent parts: residual recursion (exact ZOH / Euler),
//! velocity filter, friction model, faults, thresholds/hysteresis/debounce, reaction requests.
//! Units: SI (rad, rad/s, Nm, N, kg, m, s). Joints and links are 0-based in code.

pub mod config;
pub mod detector;
pub mod discretisation;
pub mod error;
pub mod fault;
pub mod friction;
pub mod reaction;
pub mod velocity;
