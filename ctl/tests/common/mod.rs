//! What the `fri-ctl` tests against a running service share.
#![allow(dead_code)]

use std::path::Path;
use std::process::Output;

/// `fri-ctl ARGS… --socket SOCKET`, off the async runtime.
pub async fn fri_ctl(socket: &Path, args: &[&str]) -> Output {
    let socket = socket.to_owned();
    let args: Vec<String> = args.iter().map(|s| (*s).to_owned()).collect();
    tokio::task::spawn_blocking(move || {
        std::process::Command::new(env!("CARGO_BIN_EXE_fri-ctl"))
            .args(&args)
            .arg("--socket")
            .arg(&socket)
            .output()
            .unwrap()
    })
    .await
    .unwrap()
}
