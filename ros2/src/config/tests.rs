use super::*;

fn load(text: &str) -> Result<BridgeConfig, BridgeConfigError> {
    BridgeConfig::from_toml(text, Path::new("test.toml"))
}

fn invalid_key(text: &str) -> (String, String) {
    match load(text) {
        Err(BridgeConfigError::Invalid { key, reason }) => (key, reason),
        other => panic!("expected an invalid key, got {other:?}"),
    }
}

#[test]
fn defaults_come_from_the_service_file_and_the_builtin_model() {
    let c = load(
        "[operator]\nsocket = \"/tmp/x/op.sock\"\n[iceoryx2]\nservice_prefix = \"lab\"\nglobal_prefix = \"g_\"\n",
    )
    .unwrap();
    assert_eq!(c.service.operator.socket, Path::new("/tmp/x/op.sock"));
    assert_eq!(c.ipc_names().state(), "lab/state");
    assert_eq!(c.ipc_names().global_prefix.as_deref(), Some("g_"));
    assert_eq!(c.ros2, Ros2Config::default());
    assert_eq!(c.joint_names[0], "lwr_joint_1");
    assert_eq!(c.joint_names[6], "lwr_joint_7");
    assert_eq!(c.joint_states_every, 4);
    assert_eq!(c.in_namespace("payload"), "/lwr/payload");
    assert!(c.addresses.is_empty());
}

#[test]
fn the_ros2_table_is_read_and_every_cycle_is_allowed() {
    let c = load(
        "[ros2]\nnamespace = \"/lab/arm_1\"\ndomain_id = 232\njoint_states_hz = 1000\n\
         diagnostics_hz = 2.0\njoint_names = [\"a1\", \"a2\", \"e1\", \"a3\", \"a4\", \"a5\", \"a6\"]\n\
         interface = \"lo\"\nservice_mapping = \"cyclone\"\n",
    )
    .unwrap();
    assert_eq!(c.joint_states_every, 1);
    assert_eq!(c.joint_names[2], "e1");
    assert_eq!(c.ros2.service_mapping, ServiceMappingKind::Cyclone);
    assert!(c.addresses.contains(&IpAddr::from([127, 0, 0, 1])));
    assert_eq!(c.in_namespace("stop"), "/lab/arm_1/stop");
}

#[test]
fn bad_values_name_their_key_and_range() {
    let (k, r) = invalid_key("[ros2]\ndomain_id = 233\n");
    assert_eq!(k, "ros2.domain_id");
    assert!(r.contains("0..=232"), "{r}");
    let (k, r) = invalid_key("[ros2]\njoint_states_hz = 300\n");
    assert_eq!(k, "ros2.joint_states_hz");
    assert!(r.contains("1000"), "{r}");
    let (k, r) = invalid_key("[ros2]\njoint_states_hz = 0\n");
    assert_eq!(k, "ros2.joint_states_hz");
    assert!(r.contains("1..=1000"), "{r}");
    // At a 2 ms controller cycle 1 kHz is faster than the controller.
    let (k, _) = invalid_key(
        "[fri]\ncycle_s = 0.002\nmax_joint_step = 0.0005\n[observer]\ngains = 200.0\n[ros2]\njoint_states_hz = 1000\n",
    );
    assert_eq!(k, "ros2.joint_states_hz");
    let (k, r) = invalid_key("[ros2]\ndiagnostics_hz = 0.0\n");
    assert_eq!(k, "ros2.diagnostics_hz");
    assert!(r.contains("0.1..=10"), "{r}");
    for ns in ["lwr", "/lwr/", "/9lwr", "/a//b", "/a__b", "/a-b"] {
        let (k, _) = invalid_key(&format!("[ros2]\nnamespace = \"{ns}\"\n"));
        assert_eq!(k, "ros2.namespace", "{ns}");
    }
    let (k, r) = invalid_key("[ros2]\njoint_names = [\"a\", \"b\"]\n");
    assert_eq!(k, "ros2.joint_names");
    assert!(r.contains("2 joint names") && r.contains('7'), "{r}");
    let (k, r) =
        invalid_key("[ros2]\njoint_names = [\"a\", \"b\", \"c\", \"d\", \"e\", \"f\", \"a\"]\n");
    assert_eq!(k, "ros2.joint_names");
    assert!(r.contains("twice"), "{r}");
    let (k, _) = invalid_key("[ros2]\ninterface = \"no-such-if0\"\n");
    assert_eq!(k, "ros2.interface");
    let (k, _) = invalid_key("[ros2]\nrobot_description = \"/nonexistent/robot.urdf\"\n");
    assert_eq!(k, "ros2.robot_description");
    let (k, _) = invalid_key("[ros2]\npayload_frame = \"\"\n");
    assert_eq!(k, "ros2.payload_frame");
}

#[test]
fn unknown_keys_and_bad_service_values_are_refused() {
    match load("[ros2]\nnamspace = \"/x\"\n") {
        Err(BridgeConfigError::Parse { message, .. }) => {
            assert!(message.contains("namspace"), "{message}")
        }
        other => panic!("{other:?}"),
    }
    match load("[fri]\ncycle_s = 5.0\n") {
        Err(BridgeConfigError::Invalid { key, .. }) => assert_eq!(key, "fri.cycle_s"),
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        load("[nonsense]\n"),
        Err(BridgeConfigError::Parse { .. })
    ));
}

#[test]
fn the_service_example_file_configures_the_bridge_with_its_defaults() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../daemon/config/fri-service.example.toml");
    let c = BridgeConfig::load(&path).unwrap();
    assert_eq!(c.ros2, Ros2Config::default());
    assert_eq!(c.service.ros2, None);
    assert_eq!(
        c.service.operator.socket,
        fri_service::config::Config::default().operator.socket
    );
}
