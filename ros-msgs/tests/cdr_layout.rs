//! The bytes ROS 2 expects: CDR layouts written out by hand from the OMG CDR rules (alignment of
//! each primitive to its size, counted from the end of the encapsulation header), and schemas.
#![allow(clippy::unwrap_used, missing_docs)]

use fri_ros_msgs::builtin_interfaces::Time;
use fri_ros_msgs::diagnostic_msgs::{DiagnosticArray, DiagnosticStatus, KeyValue};
use fri_ros_msgs::fri_msgs::Collision;
use fri_ros_msgs::geometry_msgs::{Inertia, InertiaStamped, Vector3};
use fri_ros_msgs::sensor_msgs::JointState;
use fri_ros_msgs::std_msgs::Header;
use fri_ros_msgs::{RosMessage, decode_cdr, encode_cdr};

fn header(sec: i32, nanosec: u32, frame: &str) -> Header {
    Header {
        stamp: Time { sec, nanosec },
        frame_id: frame.to_owned(),
    }
}

#[test]
fn joint_state_has_the_ros2_cdr_layout() {
    let msg = JointState {
        header: header(3, 500, ""),
        name: vec!["a".into()],
        position: vec![1.5],
        velocity: vec![],
        effort: vec![-2.0],
    };
    let bytes = encode_cdr(&msg).unwrap();
    let mut expected = vec![0, 1, 0, 0];
    expected.extend(3i32.to_le_bytes()); // stamp.sec           @0
    expected.extend(500u32.to_le_bytes()); // stamp.nanosec     @4
    expected.extend(1u32.to_le_bytes()); // frame_id length incl. NUL @8
    expected.push(0); //                                         @12
    expected.extend([0, 0, 0]); // pad to 4
    expected.extend(1u32.to_le_bytes()); // name: 1 string      @16
    expected.extend(2u32.to_le_bytes()); // "a\0"               @20
    expected.extend(b"a\0");
    expected.extend([0, 0]); // pad to 4                         @26
    expected.extend(1u32.to_le_bytes()); // position: 1         @28
    expected.extend(1.5f64.to_le_bytes()); // aligned to 8      @32
    expected.extend(0u32.to_le_bytes()); // velocity: 0         @40
    expected.extend(1u32.to_le_bytes()); // effort: 1           @44
    expected.extend((-2.0f64).to_le_bytes()); //                @48
    assert_eq!(bytes, expected);
    assert_eq!(decode_cdr::<JointState>(&bytes).unwrap(), msg);
}

#[test]
fn every_message_round_trips() {
    let inertia = InertiaStamped {
        header: header(1, 2, "lwr_dh7"),
        inertia: Inertia {
            m: 3.028,
            com: Vector3::from_array([0.0, 0.001, 0.119]),
            ixx: 0.01,
            ..Inertia::default()
        },
    };
    assert_eq!(
        decode_cdr::<InertiaStamped>(&encode_cdr(&inertia).unwrap()).unwrap(),
        inertia
    );
    let diag = DiagnosticArray {
        header: header(7, 0, ""),
        status: vec![DiagnosticStatus {
            level: 1,
            name: "lwr/fri".into(),
            message: "quality ok".into(),
            hardware_id: "lwr4".into(),
            values: vec![KeyValue::new("answer rate", 0.99)],
        }],
    };
    assert_eq!(
        decode_cdr::<DiagnosticArray>(&encode_cdr(&diag).unwrap()).unwrap(),
        diag
    );
    let coll = Collision {
        header: header(9, 1, "base_link"),
        cycle: 9001,
        joint_names: vec!["j1".into(), "j2".into()],
        over_threshold: vec![false, true],
        residual: vec![0.5, 9.5],
        link: 2,
    };
    assert_eq!(
        decode_cdr::<Collision>(&encode_cdr(&coll).unwrap()).unwrap(),
        coll
    );
    assert!(decode_cdr::<Collision>(&[1, 2]).is_err());
}

#[test]
fn type_names_and_schemas_are_those_of_ros2() {
    let t = JointState::TYPE;
    assert_eq!(t.ros_name(), "sensor_msgs/msg/JointState");
    assert_eq!(t.dds_type_name(), "sensor_msgs::msg::dds_::JointState_");
    let schema = t.ros2msg_schema();
    let sep = "=".repeat(80);
    assert!(schema.starts_with("std_msgs/Header header\n"));
    // Header, then what Header uses, each once.
    let header_at = schema
        .find(&format!("{sep}\nMSG: std_msgs/Header\n"))
        .unwrap();
    let time_at = schema
        .find(&format!(
            "{sep}\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
        ))
        .unwrap();
    assert!(header_at < time_at);
    assert_eq!(schema.matches("MSG: ").count(), 2);
    // InertiaStamped uses Header and Inertia, Inertia uses Vector3.
    let s = InertiaStamped::TYPE.ros2msg_schema();
    for dep in [
        "std_msgs/Header",
        "builtin_interfaces/Time",
        "geometry_msgs/Inertia",
        "geometry_msgs/Vector3",
    ] {
        assert_eq!(
            s.matches(&format!("MSG: {dep}\n")).count(),
            1,
            "{dep} in {s}"
        );
    }
    assert!(Collision::TYPE.definition.contains("uint8 link"));
    assert_eq!(
        Collision::TYPE.dds_type_name(),
        "fri_msgs::msg::dds_::Collision_"
    );
}
