//! Kills a process in the middle of atomic writes and checks the state file is always either the
//! old or the new content, never torn. The child is this test binary re-executed with an
//! environment variable that turns `child_writer` into an endless writer.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use fri_service::persistence::atomic_write;

const ENV: &str = "FRI_SERVICE_KILL_TEST_FILE";
/// Large contents so a write takes long enough to be interrupted often.
const SIZE: usize = 4 * 1024 * 1024;

fn content(tag: u8) -> Vec<u8> {
    let mut v = vec![tag; SIZE];
    v[SIZE - 1] = b'\n';
    v
}

#[test]
#[ignore = "helper: only runs as the child of atomic_write_survives_kill"]
fn child_writer() {
    let Ok(path) = std::env::var(ENV) else {
        return;
    };
    let (a, b) = (content(b'a'), content(b'b'));
    loop {
        atomic_write(Path::new(&path), &a).unwrap();
        atomic_write(Path::new(&path), &b).unwrap();
    }
}

#[test]
fn atomic_write_survives_kill() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("payload.json");
    let exe = std::env::current_exe().unwrap();
    let valid = [content(b'a'), content(b'b')];
    let mut rng_state = 0x9e37_79b9_7f4a_7c15u64;
    for round in 0..25 {
        let mut child = Command::new(&exe)
            .args(["--exact", "child_writer", "--ignored", "--test-threads=1"])
            .env(ENV, &path)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Wait until the first write landed, then a pseudo-random extra delay so kills hit
        // every phase (write, fsync, rename).
        let t0 = Instant::now();
        while !path.exists() {
            assert!(t0.elapsed() < Duration::from_secs(20), "child never wrote");
            std::thread::sleep(Duration::from_millis(1));
        }
        rng_state ^= rng_state << 13;
        rng_state ^= rng_state >> 7;
        rng_state ^= rng_state << 17;
        std::thread::sleep(Duration::from_micros(rng_state % 40_000));
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        let got = std::fs::read(&path).unwrap();
        assert!(
            got == valid[0] || got == valid[1],
            "round {round}: torn file of {} bytes",
            got.len()
        );
    }
}
