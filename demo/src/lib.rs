//! `fri-demo`: the paper's pick-estimate-and-move experiment (`cargo run --release -- demo`),
//! the FRI daemon against an embedded simulated controller (`mock_robot::spawn`), with its plots. It lives apart from
//! the daemon and the operator client so that mock-robot and plotters stay out of both.

pub mod plots;
pub mod ros2;
pub mod run;
