use std::os::unix::fs::PermissionsExt as _;

use super::*;

fn keys(commands: &[&str]) -> (Vec<String>, AccessKeys<'static>) {
    let c: Vec<String> = commands.iter().map(|s| (*s).to_owned()).collect();
    let k = AccessKeys {
        commands: &[],
        allow_disarm: false,
        allow_resume: false,
        allow_motion: false,
        security_enclave: None,
        allow_unauthenticated_commands: true,
        request_max_age_s: 5.0,
        max_requests_in_flight: 8,
    };
    (c, k)
}

fn invalid_key(r: Result<Access, ConfigError>) -> (String, String) {
    match r {
        Err(ConfigError::Invalid { key, reason }) => (key, reason),
        other => panic!("expected an invalid key, got {other:?}"),
    }
}

#[test]
fn read_only_by_default() {
    let (_, mut k) = keys(&[]);
    k.allow_unauthenticated_commands = false;
    let a = validate(k).unwrap();
    assert!(a.commands.is_empty());
    assert_eq!(a.authentication, Authentication::ReadOnly);
    assert!(CommandName::ALL.iter().all(|c| !a.enabled(*c)));
}

#[test]
fn unknown_or_repeated_names_are_refused_naming_the_allowed_ones() {
    let (c, mut k) = keys(&["stop", "disarm"]);
    k.commands = &c;
    let (key, reason) = invalid_key(validate(k));
    assert_eq!(key, "ros2.commands");
    assert!(reason.contains("`disarm`"), "{reason}");
    for name in CommandName::ALL {
        assert!(reason.contains(name.as_str()), "{reason}");
    }
    let (c, mut k) = keys(&["stop", "stop"]);
    k.commands = &c;
    assert!(invalid_key(validate(k)).1.contains("twice"));
}

#[test]
fn resume_motion_and_disarm_need_their_own_enablement() {
    for (cmd, key) in [
        ("resume", "ros2.allow_resume"),
        ("tare", "ros2.allow_motion"),
        ("estimate_payload", "ros2.allow_motion"),
    ] {
        let (c, mut k) = keys(&[cmd]);
        k.commands = &c;
        let (bad, reason) = invalid_key(validate(k));
        assert_eq!(bad, "ros2.commands");
        assert!(reason.contains(key), "{reason}");
    }
    let (c, mut k) = keys(&["resume", "tare", "estimate_payload"]);
    k.commands = &c;
    k.allow_resume = true;
    k.allow_motion = true;
    assert!(validate(k).is_ok());
    // collision_arm alone arms but does not disarm.
    let (c, mut k) = keys(&["collision_arm"]);
    k.commands = &c;
    let a = validate(k).unwrap();
    assert!(a.enabled(CommandName::CollisionArm) && !a.allow_disarm);
    k.allow_disarm = true;
    assert!(validate(k).unwrap().allow_disarm);
    // An enablement without its command is a mistake.
    let (c, mut k) = keys(&["stop"]);
    k.commands = &c;
    k.allow_disarm = true;
    assert_eq!(invalid_key(validate(k)).0, "ros2.allow_disarm");
    k.allow_disarm = false;
    k.allow_motion = true;
    assert_eq!(invalid_key(validate(k)).0, "ros2.allow_motion");
    k.allow_motion = false;
    k.allow_resume = true;
    assert_eq!(invalid_key(validate(k)).0, "ros2.allow_resume");
}

#[test]
fn commands_need_an_enclave_or_the_explicit_unauthenticated_mode() {
    let (c, mut k) = keys(&["stop"]);
    k.commands = &c;
    assert_eq!(
        validate(k).unwrap().authentication,
        Authentication::Unauthenticated
    );
    k.allow_unauthenticated_commands = false;
    let (key, reason) = invalid_key(validate(k));
    assert_eq!(key, "ros2.commands");
    assert!(
        reason.contains("ros2.security_enclave")
            && reason.contains("ros2.allow_unauthenticated_commands"),
        "{reason}"
    );
    // Unauthenticated mode with nothing to command is refused (it would only warn).
    let (_, k) = keys(&[]);
    assert_eq!(
        invalid_key(validate(k)).0,
        "ros2.allow_unauthenticated_commands"
    );
    let (c, mut k) = keys(&["stop"]);
    k.commands = &c;
    let dir = Path::new("/nonexistent-enclave");
    k.security_enclave = Some(dir);
    assert_eq!(
        invalid_key(validate(k)).0,
        "ros2.allow_unauthenticated_commands"
    );
    k.allow_unauthenticated_commands = false;
    let (key, reason) = invalid_key(validate(k));
    assert_eq!(key, "ros2.security_enclave");
    assert!(reason.contains("nonexistent-enclave"), "{reason}");
}

#[test]
fn the_age_bound_and_the_concurrency_are_bounded() {
    let (c, mut k) = keys(&["stop"]);
    k.commands = &c;
    for age in [0.0, 60.5, f64::NAN] {
        k.request_max_age_s = age;
        assert_eq!(invalid_key(validate(k)).0, "ros2.request_max_age_s");
    }
    k.request_max_age_s = 5.0;
    for n in [0, 65] {
        k.max_requests_in_flight = n;
        assert_eq!(invalid_key(validate(k)).0, "ros2.max_requests_in_flight");
    }
}

fn enclave() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o700)).unwrap();
    for name in ENCLAVE_FILES {
        let p = dir.path().join(name);
        std::fs::write(&p, "x").unwrap();
        let mode = if name == "key.pem" { 0o600 } else { 0o644 };
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(mode)).unwrap();
    }
    dir
}

#[test]
fn an_enclave_is_checked_like_sshd_strict_modes() {
    let dir = enclave();
    check_enclave(dir.path()).unwrap();
    let set = |p: &Path, mode: u32| {
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
    };
    // Writable by others.
    set(dir.path(), 0o777);
    assert!(check_enclave(dir.path()).unwrap_err().contains("writable"));
    set(dir.path(), 0o700);
    // A readable private key.
    let key = dir.path().join("key.pem");
    set(&key, 0o644);
    assert!(
        check_enclave(dir.path())
            .unwrap_err()
            .contains("private key")
    );
    set(&key, 0o600);
    // A missing file is named with the six an enclave holds.
    std::fs::remove_file(dir.path().join("permissions.p7s")).unwrap();
    let e = check_enclave(dir.path()).unwrap_err();
    assert!(
        e.contains("permissions.p7s") && e.contains("governance.p7s"),
        "{e}"
    );
    // Owned by another user (the tests run as root, as CI does: chown to nobody).
    let other = enclave();
    std::os::unix::fs::chown(other.path(), Some(65534), None).unwrap();
    assert!(
        check_enclave(other.path())
            .unwrap_err()
            .contains("owned by uid 65534")
    );
}
