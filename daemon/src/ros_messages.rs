//! The service's messages as ROS 2 messages (no DDS here): what the bridge `fri-ros2` publishes
//! and what `record --kind mcap` writes are built by the same functions, so both carry the same
//! fields, units, frames and stamps (`docs/ros2.md`).

use fri_api::JOINTS;
use fri_api::ipc::{CollisionMessage, PayloadEstimate, RobotState};
use fri_api::results::AppliedPayload;
use fri_ros_msgs::builtin_interfaces::Time;
use fri_ros_msgs::fri_msgs::Collision;
use fri_ros_msgs::geometry_msgs::{Inertia, InertiaStamped, Vector3, Wrench, WrenchStamped};
use fri_ros_msgs::sensor_msgs::JointState;
use fri_ros_msgs::std_msgs::Header;

/// Frame of the collision message (the URDF's root).
pub const BASE_FRAME: &str = "base_link";
/// Name of the frame the built-in description adds for DH frame 7 (the payload's frame).
pub const DH_FRAME_7: &str = "lwr_dh_frame_7";
/// Name of the frame the built-in description adds for DH frame 0 (the dynamics model's base:
/// the shoulder, 0.3105 m above `base_link`, same axes), the frame of the contact wrench.
pub const DH_FRAME_0: &str = "lwr_dh_frame_0";
/// Frame of the contact wrench: the monitor's contact fit gives force and moment about the
/// origin of the dynamics model's base frame, DH frame 0.
pub const CONTACT_FRAME: &str = DH_FRAME_0;
/// Topic of the joint states (global, as `robot_state_publisher` expects).
pub const JOINT_STATES_TOPIC: &str = "/joint_states";
/// Topic of the robot description (global).
pub const ROBOT_DESCRIPTION_TOPIC: &str = "/robot_description";
/// Namespace of the service's own topics unless `ros2.namespace` says otherwise.
pub const DEFAULT_NAMESPACE: &str = "/lwr";

/// The project's LWR 4+ model (`dynamics/robots/lwr4.urdf`).
const LWR4_URDF: &str = include_str!("../../dynamics/robots/lwr4.urdf");
/// Pose of DH frame 7 in URDF link 7 (tools/gen_lwr4_urdf.py, `DH_IN_URDF[6]`: no rotation,
/// z −0.078 m).
const DH_FRAME_7_JOINT: &str = r#"  <!-- Added by the FRI service: frame 7 of the paper's DH table, in which the payload's centre of
       mass is given (tools/gen_lwr4_urdf.py, DH_IN_URDF). -->
  <joint name="lwr_dh_frame_7_joint" type="fixed">
    <parent link="lwr_link_7"/>
    <child link="lwr_dh_frame_7"/>
    <origin xyz="0 0 -0.078" rpy="0 0 0"/>
  </joint>
  <link name="lwr_dh_frame_7"/>
  <!-- Added by the FRI service: frame 0 of the paper's DH table (the base of the dynamics model,
       at the shoulder), the frame of the estimated contact wrench. -->
  <joint name="lwr_dh_frame_0_joint" type="fixed">
    <parent link="base_link"/>
    <child link="lwr_dh_frame_0"/>
    <origin xyz="0 0 0.3105" rpy="0 0 0"/>
  </joint>
  <link name="lwr_dh_frame_0"/>
"#;

/// The joint names of the built-in description, joint 1 first.
pub const JOINT_NAMES: [&str; JOINTS] = [
    "lwr_joint_1",
    "lwr_joint_2",
    "lwr_joint_3",
    "lwr_joint_4",
    "lwr_joint_5",
    "lwr_joint_6",
    "lwr_joint_7",
];

/// The built-in robot description: the LWR 4+ URDF with [`DH_FRAME_7`] added as a fixed child
/// of its last link and [`DH_FRAME_0`] as a fixed child of `base_link`.
pub fn robot_description() -> String {
    match LWR4_URDF.rfind("</robot>") {
        Some(end) => format!(
            "{}{DH_FRAME_7_JOINT}{}",
            &LWR4_URDF[..end],
            &LWR4_URDF[end..]
        ),
        // The file is part of this repository and ends with `</robot>` (tested).
        None => LWR4_URDF.to_owned(),
    }
}

/// [`JOINT_NAMES`] as owned strings.
pub fn joint_names() -> [String; JOINTS] {
    JOINT_NAMES.map(str::to_owned)
}

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

/// The contact wrench of a collision onset as ROS expects it: the monitor's contact fit (any
/// link) as force (N) and moment p × F about the origin of [`CONTACT_FRAME`] (Nm), base axes.
/// `None` when the fit did not run (confidence 0).
pub fn contact_wrench(event: &CollisionMessage) -> Option<WrenchStamped> {
    if event.confidence <= 0.0 {
        return None;
    }
    let w = &event.wrench;
    Some(WrenchStamped {
        header: header(event.time_s, CONTACT_FRAME),
        wrench: Wrench {
            force: Vector3::from_array([w[0], w[1], w[2]]),
            torque: Vector3::from_array([w[3], w[4], w[5]]),
        },
    })
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

    #[test]
    fn the_description_adds_frame_7_to_the_lwr_model() {
        let urdf = robot_description();
        assert!(urdf.trim_end().ends_with("</robot>"));
        assert!(urdf.contains(r#"<child link="lwr_dh_frame_7"/>"#));
        for name in JOINT_NAMES {
            assert!(urdf.contains(&format!(r#"<joint name="{name}""#)), "{name}");
        }
    }

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
    fn the_contact_wrench_is_the_fits_base_frame_wrench_and_absent_without_a_fit() {
        let mut e = CollisionMessage {
            cycle: 10,
            time_s: 0.01,
            link: 5,
            confidence: 0.9,
            contact_point: [0.1, 0.0, 0.5],
            wrench: [0.0, 0.0, -20.0, 0.0, 2.0, 0.0],
            ..CollisionMessage::default()
        };
        let w = contact_wrench(&e).unwrap();
        assert_eq!(w.header.frame_id, CONTACT_FRAME);
        assert_eq!(w.header.stamp, header(0.01, CONTACT_FRAME).stamp);
        assert_eq!(w.wrench.force.z, -20.0);
        assert_eq!(w.wrench.torque.y, 2.0);
        e.confidence = 0.0;
        assert_eq!(contact_wrench(&e), None);
    }

    #[test]
    fn the_description_places_dh_frame_0_at_the_shoulder() {
        // Joint 1 sits 0.11 m above base_link and joint 2 0.2005 m above joint 1: the shoulder,
        // where DH frame 0 has its origin, is 0.3105 m up.
        let d = robot_description();
        assert!(d.contains(r#"<child link="lwr_dh_frame_0"/>"#));
        assert!(LWR4_URDF.contains(r#"<origin xyz="0 0 0.11" rpy="0 0 0"/>"#));
        assert!(LWR4_URDF.contains(r#"<origin xyz="0 0 0.2005" rpy="0 0 0"/>"#));
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
