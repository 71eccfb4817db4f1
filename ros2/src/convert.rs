//! The service's iceoryx2 messages as ROS 2 messages (no DDS here).

use fri_api::ipc::{CollisionMessage, PayloadEstimate, RobotState};
use fri_api::results::AppliedPayload;
use fri_ros_msgs::builtin_interfaces::Time;
use fri_ros_msgs::fri_msgs::Collision;
use fri_ros_msgs::geometry_msgs::{Inertia, InertiaStamped, Vector3};
use fri_ros_msgs::sensor_msgs::JointState;
use fri_ros_msgs::std_msgs::Header;

use crate::config::JOINTS;

/// Frame of the collision message (the URDF's root).
pub const BASE_FRAME: &str = "base_link";

/// The three joint-state messages of one robot state.
#[derive(Debug, Clone, PartialEq)]
pub struct JointStates {
    /// `/joint_states`: q (rad), q̇ (rad/s), measured τ_J (Nm).
    pub measured: JointState,
    /// `<ns>/external_torque`: the observer residual as effort, Nm (NaN while invalid).
    pub external_torque: JointState,
    /// `<ns>/controller_gravity`: the controller's gravity torques as effort, Nm.
    pub controller_gravity: JointState,
}

fn header(time_s: f64, frame: &str) -> Header {
    Header {
        stamp: Time::from_seconds(time_s),
        frame_id: frame.to_owned(),
    }
}

fn effort_only(state: &RobotState, names: &[String; JOINTS], effort: &[f64; JOINTS]) -> JointState {
    JointState {
        header: header(state.time_s, ""),
        name: names.to_vec(),
        position: Vec::new(),
        velocity: Vec::new(),
        effort: effort.to_vec(),
    }
}

/// The joint-state messages of `state`, stamped with its controller time.
pub fn joint_states(state: &RobotState, names: &[String; JOINTS]) -> JointStates {
    JointStates {
        measured: JointState {
            header: header(state.time_s, ""),
            name: names.to_vec(),
            position: state.q.to_vec(),
            velocity: state.qd.to_vec(),
            effort: state.tau.to_vec(),
        },
        external_torque: effort_only(state, names, &state.residual),
        controller_gravity: effort_only(state, names, &state.gravity),
    }
}

/// The collision message of an iceoryx2 collision event.
pub fn collision(event: &CollisionMessage, names: &[String; JOINTS]) -> Collision {
    Collision {
        header: header(event.time_s, BASE_FRAME),
        cycle: event.cycle,
        joint_names: names.to_vec(),
        over_threshold: (0..JOINTS)
            .map(|i| event.joints_mask & (1 << i) != 0)
            .collect(),
        residual: event.residual.to_vec(),
        link: u8::try_from(event.link).unwrap_or(0),
    }
}

/// A payload of mass `m` (kg) at `com` (m, in `frame`) as a point mass (the service estimates no
/// rotational inertia: the tensor is zero).
pub fn payload(time_s: f64, m: f64, com: [f64; 3], frame: &str) -> InertiaStamped {
    InertiaStamped {
        header: header(time_s, frame),
        inertia: Inertia {
            m,
            com: Vector3::from_array(com),
            ..Inertia::default()
        },
    }
}

/// The applied payload of an iceoryx2 payload message; `None` for an estimate that was not
/// applied (a cleared payload is `Some` with mass 0).
pub fn applied_payload(p: &PayloadEstimate, frame: &str) -> Option<InertiaStamped> {
    let cleared = p.applied == 0 && p.mass == 0.0;
    (p.applied == 1 || cleared).then(|| payload(p.time_s, p.mass, p.com, frame))
}

/// The payload `status` reports (`None`: none applied, published as mass 0).
pub fn status_payload(p: Option<&AppliedPayload>, time_s: f64, frame: &str) -> InertiaStamped {
    match p {
        Some(p) => payload(time_s, p.mass, p.com, frame),
        None => payload(time_s, 0.0, [0.0; 3], frame),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> [String; JOINTS] {
        std::array::from_fn(|i| format!("j{}", i + 1))
    }

    #[test]
    fn a_state_becomes_three_joint_states_stamped_with_controller_time() {
        let mut s = RobotState {
            cycle: 1500,
            time_s: 1.5,
            ..RobotState::default()
        };
        s.q[0] = 0.25;
        s.qd[6] = -0.5;
        s.tau[3] = 12.0;
        s.residual[2] = 3.0;
        s.gravity[1] = -40.0;
        let m = joint_states(&s, &names());
        assert_eq!(
            m.measured.header.stamp,
            Time {
                sec: 1,
                nanosec: 500_000_000
            }
        );
        assert_eq!(m.measured.name[6], "j7");
        assert_eq!(m.measured.position[0], 0.25);
        assert_eq!(m.measured.velocity[6], -0.5);
        assert_eq!(m.measured.effort[3], 12.0);
        assert_eq!(m.external_torque.effort[2], 3.0);
        assert!(m.external_torque.position.is_empty());
        assert_eq!(m.controller_gravity.effort[1], -40.0);
    }

    #[test]
    fn collision_mask_becomes_flags_per_joint() {
        let e = CollisionMessage {
            cycle: 8000,
            time_s: 8.0,
            residual: [0.0, 0.0, 0.0, 9.5, 0.0, 7.0, 0.0],
            joints_mask: 0b10_1000,
            link: 6,
            ..CollisionMessage::default()
        };
        let c = collision(&e, &names());
        assert_eq!(
            c.over_threshold,
            vec![false, false, false, true, false, true, false]
        );
        assert_eq!(c.link, 6);
        assert_eq!(c.header.frame_id, BASE_FRAME);
        assert_eq!(c.residual[3], 9.5);
    }

    #[test]
    fn only_applied_or_cleared_payloads_are_the_applied_payload() {
        let mut p = PayloadEstimate {
            time_s: 2.0,
            mass: 3.0,
            com: [0.0, 0.0, 0.1],
            applied: 1,
            ..PayloadEstimate::default()
        };
        let a = applied_payload(&p, "f7").unwrap();
        assert_eq!(a.inertia.m, 3.0);
        assert_eq!(a.inertia.com.z, 0.1);
        assert_eq!(a.header.frame_id, "f7");
        p.applied = 0;
        assert_eq!(applied_payload(&p, "f7"), None);
        p.mass = 0.0;
        assert_eq!(applied_payload(&p, "f7").unwrap().inertia.m, 0.0);
    }
}
