//! Defaults, the example file, and errors that name the dotted key.

use std::path::Path;

use super::*;

fn invalid_key(text: &str) -> String {
    match Config::from_toml(text) {
        Err(ConfigError::Invalid { key, .. }) => key,
        other => panic!("expected Invalid, got {other:?}"),
    }
}

#[test]
fn empty_file_gives_documented_defaults() {
    let c = Config::from_toml("").unwrap();
    assert_eq!(c.fri.bind, "0.0.0.0:49938".parse().unwrap());
    assert_eq!(c.fri.cycle_s, 0.001);
    assert_eq!(c.observer.thresholds, [6.0; 7]);
    assert_eq!(c.reaction.policy, ReactionMode::Stop);
    assert_eq!(c.estimation.settle_timeout_s, 1.0);
    assert_eq!(c.operator.socket, PathBuf::from(DEFAULT_SOCKET));
    assert_eq!(c.state.dir, default_state_dir());
    assert_eq!(c.state.record_dir(), default_state_dir().join("recordings"));
    let c = Config::from_toml("[state]\ndir = \"/var/lib/fri\"\n").unwrap();
    assert_eq!(
        c.state.record_dir(),
        PathBuf::from("/var/lib/fri/recordings")
    );
    let c = Config::from_toml("[state]\nrecord_dir = \"/data/rec\"\n").unwrap();
    assert_eq!(c.state.record_dir(), PathBuf::from("/data/rec"));
}

#[test]
fn the_default_state_directory_is_systemds_else_var_lib_never_tmp() {
    assert_eq!(state_dir_from(None), PathBuf::from("/var/lib/fri-service"));
    let systemd = |v: &str| state_dir_from(Some(v.into()));
    assert_eq!(systemd("/var/lib/fri"), PathBuf::from("/var/lib/fri"));
    assert_eq!(
        systemd("/var/lib/a:/var/lib/b"),
        PathBuf::from("/var/lib/a")
    );
    assert_eq!(systemd("relative"), PathBuf::from(DEFAULT_STATE_DIR));
    assert_eq!(systemd(""), PathBuf::from(DEFAULT_STATE_DIR));
    assert!(!DEFAULT_STATE_DIR.starts_with("/tmp") && !DEFAULT_SOCKET.starts_with("/tmp"));
}

#[test]
fn example_file_parses_and_matches_defaults() {
    let text = include_str!("../../config/fri-service.example.toml");
    let mut c = Config::from_toml(text).unwrap();
    // The `[ros2]` table is the bridge's (fri-ros2 checks it); the service keeps it as read.
    assert!(c.ros2.take().is_some_and(|t| t.contains_key("namespace")));
    assert_eq!(c, Config::default());
}

#[test]
fn the_service_reads_the_bridges_unauthenticated_commands_key_typed() {
    let c = Config::from_toml("[ros2]\nnamespace = \"/lwr\"\n").unwrap();
    assert!(!c.ros2_unauthenticated_commands());
    let c = Config::from_toml("[ros2]\nallow_unauthenticated_commands = true\n").unwrap();
    assert!(c.ros2_unauthenticated_commands());
    let err = Config::from_toml("[ros2]\nallow_unauthenticated_commands = \"yes\"\n").unwrap_err();
    assert!(
        err.to_string()
            .contains("ros2.allow_unauthenticated_commands"),
        "{err}"
    );
}

#[test]
fn unknown_key_is_rejected_with_its_name() {
    let err = Config::from_toml("[fri]\nbnid = \"0.0.0.0:1\"\n").unwrap_err();
    let text = err.to_string();
    assert!(text.contains("bnid"), "{text}");
}

#[test]
fn unknown_section_is_rejected() {
    assert!(matches!(
        Config::from_toml("[fri2]\n"),
        Err(ConfigError::Parse { .. })
    ));
}

#[test]
fn bad_values_name_the_key() {
    assert_eq!(invalid_key("[fri]\ncycle_s = 0.5\n"), "fri.cycle_s");
    assert_eq!(invalid_key("[robot]\nmodel = \"puma\"\n"), "robot.model");
    assert_eq!(
        invalid_key("[motion]\nmax_jerk = [5.0, 5.0, -1.0, 5.0, 5.0, 5.0, 5.0]\n"),
        "motion.max_jerk[2] (joint 3)"
    );
    assert_eq!(
        invalid_key("[motion]\nmax_velocity = [0.5, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]\n"),
        "motion.max_velocity[0] (joint 1)"
    );
    assert_eq!(
        invalid_key("[estimation]\nsettle_window_s = 2.0\n"),
        "estimation.settle_window_s"
    );
    assert_eq!(
        invalid_key("[operator]\nmax_line_bytes = 10\n"),
        "operator.max_line_bytes"
    );
    assert_eq!(
        invalid_key("[state]\nrecord_dir = \"\"\n"),
        "state.record_dir"
    );
    assert_eq!(
        invalid_key("[operator]\nidle_timeout_s = 0.5\n"),
        "operator.idle_timeout_s"
    );
    assert_eq!(
        invalid_key("[operator]\nidle_timeout_s = nan\n"),
        "operator.idle_timeout_s"
    );
    assert_eq!(
        invalid_key("[iceoryx2]\nglobal_prefix = \"a b\"\n"),
        "iceoryx2.global_prefix"
    );
    assert_eq!(
        invalid_key("[operator]\nstop_socket = \"\"\n"),
        "operator.stop_socket"
    );
    assert_eq!(
        invalid_key("[operator]\nsocket = \"/run/a.sock\"\nstop_socket = \"/run/a.sock\"\n"),
        "operator.stop_socket"
    );
}

#[test]
fn the_stop_socket_defaults_to_beside_the_operator_socket() {
    let c = Config::from_toml("[operator]\nsocket = \"/run/lwr/op.sock\"\n").unwrap();
    assert_eq!(
        c.operator.stop_socket_path(),
        PathBuf::from("/run/lwr/op.stop.sock")
    );
    let c = Config::from_toml("[operator]\nstop_socket = \"/run/lwr/stop\"\n").unwrap();
    assert_eq!(
        c.operator.stop_socket_path(),
        PathBuf::from("/run/lwr/stop")
    );
}

fn invalid(text: &str) -> (String, String) {
    match Config::from_toml(text) {
        Err(ConfigError::Invalid { key, reason }) => (key, reason),
        other => panic!("expected Invalid for {text:?}, got {other:?}"),
    }
}

#[test]
fn every_numeric_key_out_of_range_is_rejected_naming_the_key_and_range() {
    let seven = |v: &str| format!("[{v}, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]");
    let cases = [
        (
            "[fri]\ncycle_s = 1e300\n".to_owned(),
            "fri.cycle_s",
            "0.001…0.1 s",
        ),
        (
            "[fri]\ncontroller_port = 0\n".to_owned(),
            "fri.controller_port",
            "1…65535",
        ),
        (
            "[fri]\nresync_after_s = 0.001\n".to_owned(),
            "fri.resync_after_s",
            "0.01…10 s",
        ),
        (
            "[fri]\nmax_joint_step = 1e300\n".to_owned(),
            "fri.max_joint_step",
            "1e-6…0.0015 rad",
        ),
        (
            format!("[observer]\ngains = {}\n", seven("1e308")),
            "observer.gains[0] (joint 1)",
            "1e308 1/s is outside 1…500 1/s",
        ),
        (
            "[observer]\nthresholds = [6.0, 6.0, 6.0, 1e300, 6.0, 6.0, 6.0]\n".to_owned(),
            "observer.thresholds[3] (joint 4)",
            "1e300 Nm is outside 0.1…25 Nm",
        ),
        (
            "[observer]\nthresholds = [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 0.05]\n".to_owned(),
            "observer.thresholds[6] (joint 7)",
            "0.05 Nm is outside 0.1…9.5 Nm",
        ),
        (
            "[reaction]\npause_s = 1e300\n".to_owned(),
            "reaction.pause_s",
            "0…60 s",
        ),
        (
            format!("[motion]\nmax_velocity = {}\n", seven("0.001")),
            "motion.max_velocity[0] (joint 1)",
            "0.001 rad/s is outside 0.01…0.2 rad/s",
        ),
        (
            format!("[motion]\nmax_acceleration = {}\n", seven("1e9")),
            "motion.max_acceleration[0] (joint 1)",
            "0.01…10 rad/s²",
        ),
        (
            format!("[motion]\nmax_jerk = {}\n", seven("1e9")),
            "motion.max_jerk[0] (joint 1)",
            "0.1…1000 rad/s³",
        ),
        (
            "[motion]\nmax_around_distance_rad = 1e300\n".to_owned(),
            "motion.max_around_distance_rad",
            "0.01…1 rad",
        ),
        (
            "[estimation]\nsettle_velocity = 1e300\n".to_owned(),
            "estimation.settle_velocity",
            "0.0001…0.1 rad/s",
        ),
        (
            "[estimation]\nsettle_torque_std = 1e300\n".to_owned(),
            "estimation.settle_torque_std",
            "0.001…5 Nm",
        ),
        (
            "[estimation]\nsettle_timeout_s = 1e300\n".to_owned(),
            "estimation.settle_timeout_s",
            "0.01…60 s",
        ),
        (
            "[estimation]\nsettle_window_s = 0.0\n".to_owned(),
            "estimation.settle_window_s",
            "0.001…1 s",
        ),
        (
            "[estimation]\naverage_s = 1e300\n".to_owned(),
            "estimation.average_s",
            "0.001…60 s",
        ),
        (
            "[estimation]\npattern_step_deg = 0.5\n".to_owned(),
            "estimation.pattern_step_deg",
            "1…30 deg",
        ),
        (
            "[estimation]\npattern_poses = 1000\n".to_owned(),
            "estimation.pattern_poses",
            "2…100",
        ),
        (
            "[operator]\nmax_line_bytes = 10\n".to_owned(),
            "operator.max_line_bytes",
            "256…16777216 bytes",
        ),
        (
            "[unknown_payload]\ngrasp_window_s = 0.1\n".to_owned(),
            "unknown_payload.grasp_window_s",
            "0.5…120 s",
        ),
        (
            "[unknown_payload]\nsettle_s = 60\n".to_owned(),
            "unknown_payload.settle_s",
            "0.05…5 s",
        ),
        (
            "[unknown_payload]\nexpire_s = inf\n".to_owned(),
            "unknown_payload.expire_s",
            "5…3600 s",
        ),
        (
            "[operator]\nmax_clients = 0\n".to_owned(),
            "operator.max_clients",
            "1…4096",
        ),
        (
            format!("[operator]\nallowed_uids = {:?}\n", vec![1000u32; 300]),
            "operator.allowed_uids",
            "0…256 entries",
        ),
        (
            format!("[operator]\nallowed_gids = {:?}\n", vec![1000u32; 300]),
            "operator.allowed_gids",
            "0…256 entries",
        ),
    ];
    for (text, key, range) in cases {
        let (k, reason) = invalid(&text);
        assert_eq!(k, key, "{text}");
        assert!(reason.contains(range), "{text}: {reason}");
        assert!(
            reason.contains("is outside") || key == "fri.controller_port",
            "{reason}"
        );
    }
}

#[test]
fn ranges_follow_the_configured_cycle() {
    // At 10 ms the gain limit is 50 1/s and the resync floor 0.1 s.
    let (k, reason) = invalid(
        "[fri]\ncycle_s = 0.01\nmax_joint_step = 0.002\n[motion]\nmax_velocity = \
         [0.18, 0.18, 0.18, 0.18, 0.18, 0.18, 0.18]\n[observer]\ngains = \
         [400.0, 50.0, 50.0, 50.0, 50.0, 50.0, 50.0]\n",
    );
    assert_eq!(k, "observer.gains[0] (joint 1)");
    assert!(reason.contains("1…50 1/s"), "{reason}");
    let (k, _) = invalid("[fri]\ncycle_s = 0.01\nmax_joint_step = 0.002\nresync_after_s = 0.05\n");
    assert_eq!(k, "fri.resync_after_s");
    let ok = Config::from_toml(
        "[fri]\ncontroller_port = 49938\nresync_after_s = 0.1\n[motion]\nmax_around_distance_rad = 0.2\n",
    )
    .unwrap();
    assert_eq!(ok.fri.controller_port, Some(49938));
}

#[test]
fn wrong_length_array_is_a_parse_error() {
    for text in [
        "[observer]\ngains = [1.0, 2.0]\n",
        "[observer]\nthresholds = [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 6.0]\n",
        "[observer]\nthresholds = \"6\"\n",
    ] {
        let err = Config::from_toml(text).unwrap_err();
        assert!(matches!(err, ConfigError::Parse { .. }), "{err}");
        assert!(err.to_string().contains("7 numbers"), "{err}");
    }
}

#[test]
fn one_threshold_or_gain_sets_every_joint() {
    let c = Config::from_toml("[observer]\nthresholds = 4.5\ngains = 300\n").unwrap();
    assert_eq!(c.observer.thresholds, [4.5; 7]);
    assert_eq!(c.observer.gains, [300.0; 7]);
    let c = Config::from_toml("[observer]\nthresholds = [9, 9, 6, 6, 4, 2, 2]\n").unwrap();
    assert_eq!(c.observer.thresholds, [9.0, 9.0, 6.0, 6.0, 4.0, 2.0, 2.0]);
    // A single value is still range-checked on every joint: 12 Nm exceeds the wrist's 9.5 Nm.
    let err = Config::from_toml("[observer]\nthresholds = 12\n").unwrap_err();
    assert!(
        err.to_string().contains("observer.thresholds[5] (joint 6)"),
        "{err}"
    );
}

#[test]
fn missing_file_is_a_read_error() {
    let err = Config::load(Path::new("/nonexistent/fri.toml")).unwrap_err();
    assert!(matches!(err, ConfigError::Read { .. }));
    // The cause chain names the I/O error once (it used to be in the message and the source).
    let chain = format!("{:#}", anyhow::Error::new(err));
    assert_eq!(
        chain.matches("No such file or directory").count(),
        1,
        "{chain}"
    );
    assert!(
        chain.starts_with("cannot read config file /nonexistent/fri.toml: "),
        "{chain}"
    );
}
