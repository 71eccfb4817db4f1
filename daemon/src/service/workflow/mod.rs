//! The operator workflows, one file per command (mini-redis `cmd/` style): each takes its
//! request's arguments, runs against the loop's ordered output ([`super::stream`]) and returns
//! its result or an error with its cause. The shared steps are a commanded move ([`motion`]), a
//! static sample ([`acquire`]), the pose pattern ([`poses`]) and the excitations ([`excite`]).

pub mod acquire;
pub mod calibrate;
pub mod calibration_recording;
pub mod calibration_report;
pub mod collision;
pub mod estimate;
pub mod estimate_verdict;
pub mod excite;
pub mod expect_payload;
pub mod install;
pub mod motion;
pub mod payload;
pub mod payload_check;
pub mod poses;
pub mod record;
pub mod sample;
pub mod status;
pub mod stop;
pub mod tare;
pub mod tare_epoch;
pub mod unknown_payload_state;
pub mod watch;
