//! The binaries' command lines: configuration errors name the key, `fri-ctl` exit codes.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::Command;

#[test]
fn fri_service_rejects_a_bad_config_with_the_key_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(
        &path,
        "[observer]\nthresholds = [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 0.0]\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-service"))
        .args(["run", "--config"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("observer.thresholds[6] (joint 7)"), "{err}");

    std::fs::write(&path, "[operator]\nsokcet = \"/tmp/x\"\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fri-service"))
        .args(["run", "--config"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("sokcet"), "{err}");
}

#[test]
fn fri_ctl_exit_code_69_when_the_service_is_unreachable() {
    let out = Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .args(["status", "--json", "--socket", "/nonexistent/fri.sock"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(69), "{out:?}");
}

#[test]
fn fri_ctl_usage_errors_are_caught_before_sending() {
    // apply-payload needs exactly three CoM coordinates.
    let out = Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
        .args([
            "apply-payload",
            "--mass",
            "3",
            "--com",
            "0,0",
            "--socket",
            "/nonexistent",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(64), "usage error: {out:?}");
}
