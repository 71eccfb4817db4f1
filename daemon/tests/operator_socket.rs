//! The operator socket server against a test handler: permissions, framing limits, malformed and
//! unknown input, streamed events and many clients.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::CommandExt as _;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use fri_api::client::Client;
use fri_api::protocol::{Command, ErrorCode, OperatorError, Reply};
use fri_service::operator::server::{self, AccessPolicy, EventSink, Handler, ServerLimits};
use serde_json::{Value, json};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};

/// Answers `status` with a counter, streams three progress events on `sample`, fails `stop`,
/// and streams `state` events on `watch` until the client is gone.
#[derive(Default)]
struct TestHandler {
    calls: AtomicUsize,
}

impl Handler for TestHandler {
    async fn handle(
        &self,
        command: Command,
        _origin: fri_api::origin::Origin,
        events: EventSink,
    ) -> Result<Value, OperatorError> {
        let n = self.calls.fetch_add(1, Ordering::SeqCst);
        match command {
            Command::Status => Ok(json!({"calls": n})),
            Command::Sample { .. } => {
                for i in 0..3 {
                    events.send("progress", json!({"step": i})).await;
                }
                Ok(json!({"done": true}))
            }
            Command::Stop => Err(OperatorError::new(ErrorCode::NotReady, "no robot")),
            Command::Watch { .. } => {
                while events.send("state", json!({})).await {
                    tokio::time::sleep(std::time::Duration::from_millis(20)).await;
                }
                Ok(json!({}))
            }
            _ => Err(OperatorError::new(ErrorCode::Failed, "not in test")),
        }
    }
}

async fn start(
    limits: ServerLimits,
) -> (
    tempfile::TempDir,
    std::path::PathBuf,
    tokio::sync::watch::Sender<bool>,
) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub/op.sock");
    let listener = server::bind(&path).await.unwrap();
    let (tx, rx) = tokio::sync::watch::channel(false);
    tokio::spawn(server::serve(
        listener,
        Arc::new(TestHandler::default()),
        AccessPolicy::default(),
        limits,
        rx,
    ));
    (dir, path, tx)
}

#[tokio::test]
async fn socket_has_mode_0660_and_refuses_double_bind() {
    let (_dir, path, _tx) = start(ServerLimits::default()).await;
    let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o660);
    assert!(matches!(
        server::bind(&path).await,
        Err(server::ServerError::InUse(_))
    ));
}

#[tokio::test]
async fn stale_socket_file_is_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("op.sock");
    drop(std::os::unix::net::UnixListener::bind(&path).unwrap());
    assert!(path.exists());
    server::bind(&path).await.unwrap();
}

#[tokio::test]
async fn bind_refuses_to_remove_anything_but_a_stale_socket() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("precious.txt");
    std::fs::write(&file, "keep me").unwrap();
    let e = server::bind(&file).await.unwrap_err().to_string();
    assert!(
        e.contains("precious.txt") && e.contains("regular file"),
        "{e}"
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");

    let sub = dir.path().join("a-directory");
    std::fs::create_dir(&sub).unwrap();
    let e = server::bind(&sub).await.unwrap_err().to_string();
    assert!(e.contains("a-directory") && e.contains("directory"), "{e}");
    assert!(sub.is_dir());

    // A symlink, even to a stale socket, is not removed (nor is its target).
    let stale = dir.path().join("stale.sock");
    drop(std::os::unix::net::UnixListener::bind(&stale).unwrap());
    let link = dir.path().join("link.sock");
    std::os::unix::fs::symlink(&stale, &link).unwrap();
    let e = server::bind(&link).await.unwrap_err().to_string();
    assert!(
        e.contains("link.sock") && e.contains("symbolic link"),
        "{e}"
    );
    assert!(std::fs::symlink_metadata(&link).is_ok() && stale.exists());
}

#[tokio::test]
async fn request_reply_and_streamed_events() {
    let (_dir, path, _tx) = start(ServerLimits::default()).await;
    let mut c = Client::connect(&path).await.unwrap();
    let r = c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
    assert_eq!(r, json!({"calls": 0}));
    let mut steps = Vec::new();
    let r = c
        .call(Command::Sample { duration_s: None }, |ev, data| {
            assert_eq!(ev, "progress");
            steps.push(data["step"].as_u64().unwrap());
        })
        .await
        .unwrap()
        .unwrap();
    assert_eq!(r, json!({"done": true}));
    assert_eq!(steps, vec![0, 1, 2]);
    let e = c.call(Command::Stop, |_, _| {}).await.unwrap().unwrap_err();
    assert_eq!(e.code, ErrorCode::NotReady);
}

#[tokio::test]
async fn malformed_unknown_and_oversized_lines_get_errors_and_connection_survives() {
    let limits = ServerLimits {
        max_line_bytes: 512,
        ..ServerLimits::default()
    };
    let (_dir, path, _tx) = start(limits).await;
    let stream = tokio::net::UnixStream::connect(&path).await.unwrap();
    let (r, mut w) = stream.into_split();
    let mut lines = BufReader::new(r).lines();
    let mut big = vec![b'{'; 100_000];
    big.push(b'\n');
    let inputs: Vec<(Vec<u8>, Option<u64>, &str)> = vec![
        (b"hello\n".to_vec(), None, "malformed"),
        (
            b"{\"id\":7,\"cmd\":\"teleport\"}\n".to_vec(),
            Some(7),
            "unknown-command",
        ),
        (big, None, "too-large"),
        (b"\xff\xfe\n".to_vec(), None, "malformed"),
        (
            b"{\"id\":8,\"cmd\":\"apply-payload\",\"mass\":1}\n".to_vec(),
            Some(8),
            "invalid-arguments",
        ),
        (b"{\"id\":9,\"cmd\":\"status\"}\n".to_vec(), Some(9), ""),
    ];
    for (input, id, code) in inputs {
        w.write_all(&input).await.unwrap();
        let line = lines.next_line().await.unwrap().unwrap();
        let reply: Reply = serde_json::from_str(&line).unwrap();
        match reply {
            Reply::Err { id: rid, error, .. } => {
                assert_eq!(rid, id, "{line}");
                assert_eq!(
                    serde_json::to_value(error.code).unwrap(),
                    json!(code),
                    "{line}"
                );
            }
            Reply::Ok { id: rid, .. } => {
                assert_eq!(code, "", "{line}");
                assert_eq!(rid, Some(9));
            }
            Reply::Event { .. } => panic!("unexpected event {line}"),
        }
    }
}

#[tokio::test]
async fn out_of_range_arguments_are_rejected_before_any_handler_runs() {
    // Issue 10 item 4: these used to be accepted (and clamped, or silently disabled detection).
    let (_dir, path, _tx) = start(ServerLimits::default()).await;
    let mut c = Client::connect(&path).await.unwrap();
    let cases = [
        (
            Command::EstimatePayload {
                around: Some([1e300; 7]),
                poses: None,
                step_deg: None,
                pattern: None,
                use_tare: None,
                apply: Some(true),
            },
            "around[0] = 1e300 rad is outside",
        ),
        (
            Command::Collision {
                action: fri_api::protocol::CollisionAction::Configure,
                thresholds: Some([1e300; 7]),
                gains: None,
                reaction: None,
                pause_s: None,
            },
            "thresholds[0] = 1e300 Nm is outside 0.1…44 Nm",
        ),
        (
            Command::Collision {
                action: fri_api::protocol::CollisionAction::Configure,
                thresholds: None,
                gains: Some([1e308; 7]),
                reaction: None,
                pause_s: None,
            },
            "gains[0] = 1e308 1/s is outside 1…500 1/s",
        ),
    ];
    for (command, expected) in cases {
        let e = c.call(command, |_, _| {}).await.unwrap().unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArguments, "{e:?}");
        assert!(e.message.starts_with(expected), "{}", e.message);
    }
    // The handler never saw them: its call counter is still at 0.
    let r = c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
    assert_eq!(r, json!({"calls": 0}));
}

#[tokio::test]
async fn half_closed_client_still_gets_its_reply() {
    let (_dir, path, _tx) = start(ServerLimits::default()).await;
    let mut stream = tokio::net::UnixStream::connect(&path).await.unwrap();
    stream
        .write_all(b"{\"id\":1,\"cmd\":\"status\"}\n")
        .await
        .unwrap();
    stream.shutdown().await.unwrap();
    let mut lines = BufReader::new(stream).lines();
    let line = lines.next_line().await.unwrap().unwrap();
    assert!(line.contains("\"ok\":true"), "{line}");
}

#[tokio::test]
async fn many_clients_at_once() {
    let (_dir, path, _tx) = start(ServerLimits::default()).await;
    let mut tasks = Vec::new();
    for _ in 0..32 {
        let path = path.clone();
        tasks.push(tokio::spawn(async move {
            let mut c = Client::connect(&path).await.unwrap();
            for _ in 0..5 {
                c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
            }
        }));
    }
    for t in tasks {
        t.await.unwrap();
    }
    // All 160 calls were answered; the counter saw each exactly once.
    let mut c = Client::connect(&path).await.unwrap();
    assert_eq!(
        c.call(Command::Status, |_, _| {}).await.unwrap().unwrap(),
        json!({"calls": 160})
    );
}

#[tokio::test]
async fn client_limit_rejects_extra_connections_with_busy() {
    let limits = ServerLimits {
        max_clients: 1,
        over_limit_grace: std::time::Duration::from_millis(100),
        ..ServerLimits::default()
    };
    let (_dir, path, _tx) = start(limits).await;
    let mut first = Client::connect(&path).await.unwrap();
    first
        .call(Command::Status, |_, _| {})
        .await
        .unwrap()
        .unwrap();
    let mut second = Client::connect(&path).await.unwrap();
    let reply = second.next_reply().await.unwrap();
    match reply {
        Reply::Err { error, .. } => assert_eq!(error.code, ErrorCode::Busy),
        other => panic!("{other:?}"),
    }
}

#[tokio::test]
async fn stop_gets_through_while_idle_clients_hold_the_connection_limit() {
    let limits = ServerLimits {
        max_clients: 2,
        ..ServerLimits::default()
    };
    let (_dir, path, _tx) = start(limits).await;
    let mut holders = Vec::new();
    for _ in 0..2 {
        let mut c = Client::connect(&path).await.unwrap();
        c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
        holders.push(c);
    }
    // The test handler answers `stop` with "no robot": that reply proves it was executed.
    let mut extra = Client::connect(&path).await.unwrap();
    let e = extra
        .call(Command::Stop, |_, _| {})
        .await
        .unwrap()
        .unwrap_err();
    assert_eq!(
        (e.code, e.message.as_str()),
        (ErrorCode::NotReady, "no robot")
    );
    // The over-limit connection served its one `stop` and is closed.
    assert!(matches!(
        extra.next_reply().await,
        Err(fri_api::client::ClientError::Closed)
    ));
    // Anything but `stop` is still refused while the limit is reached.
    let mut other = Client::connect(&path).await.unwrap();
    let e = other
        .call(Command::Status, |_, _| {})
        .await
        .unwrap()
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::Busy);
    assert!(e.message.contains("too many operator connections"), "{e:?}");
    // The holders are unaffected.
    for c in &mut holders {
        c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
    }
}

#[tokio::test]
async fn over_limit_connections_are_bounded_and_silent_ones_are_closed() {
    let limits = ServerLimits {
        max_clients: 1,
        over_limit_connections: 1,
        over_limit_grace: std::time::Duration::from_secs(1),
        ..ServerLimits::default()
    };
    let (_dir, path, _tx) = start(limits).await;
    let mut holder = Client::connect(&path).await.unwrap();
    holder
        .call(Command::Status, |_, _| {})
        .await
        .unwrap()
        .unwrap();
    // Takes the only over-limit slot and sends nothing.
    let mut silent = Client::connect(&path).await.unwrap();
    // No slot left at all: refused at once rather than queued without bound.
    let mut third = Client::connect(&path).await.unwrap();
    match third.next_reply().await.unwrap() {
        Reply::Err { error, .. } => assert_eq!(error.code, ErrorCode::Busy),
        other => panic!("{other:?}"),
    }
    // The silent one is refused after the grace period and closed.
    match silent.next_reply().await.unwrap() {
        Reply::Err { error, .. } => assert_eq!(error.code, ErrorCode::Busy),
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        silent.next_reply().await,
        Err(fri_api::client::ClientError::Closed)
    ));
}

#[tokio::test]
async fn idle_connections_are_closed_but_not_while_a_request_runs() {
    let limits = ServerLimits {
        idle_timeout: std::time::Duration::from_millis(300),
        ..ServerLimits::default()
    };
    let (_dir, path, _tx) = start(limits).await;
    // Connected first, with a `watch` in flight the whole time.
    let mut watching = Client::connect(&path).await.unwrap();
    watching
        .send_raw(b"{\"id\":1,\"cmd\":\"watch\"}\n")
        .await
        .unwrap();
    assert!(matches!(
        watching.next_reply().await.unwrap(),
        Reply::Event { .. }
    ));
    // One that never sends anything, and one that goes quiet after a request.
    let mut silent = Client::connect(&path).await.unwrap();
    let mut quiet = Client::connect(&path).await.unwrap();
    quiet
        .call(Command::Status, |_, _| {})
        .await
        .unwrap()
        .unwrap();
    for c in [&mut silent, &mut quiet] {
        match c.next_reply().await.unwrap() {
            Reply::Err {
                id: None, error, ..
            } => {
                assert_eq!(error.code, ErrorCode::Busy);
                assert!(error.message.contains("idle"), "{error:?}");
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            c.next_reply().await,
            Err(fri_api::client::ClientError::Closed)
        ));
    }
    // The watching connection has been open longer than both and still serves requests.
    watching
        .call(Command::Status, |_, _| {})
        .await
        .unwrap()
        .unwrap();
}

#[tokio::test]
async fn shutdown_stops_accepting() {
    let (_dir, path, tx) = start(ServerLimits::default()).await;
    tx.send(true).unwrap();
    tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    // The listener is dropped: connecting fails (the file stays until the service removes it).
    assert!(Client::connect(&path).await.is_err());
}

const PEER_ENV: &str = "FRI_SERVICE_PEER_TEST_SOCKET";

#[test]
#[ignore = "helper: only runs as the child of foreign_uid_is_refused"]
fn foreign_peer_child() {
    let Ok(path) = std::env::var(PEER_ENV) else {
        return;
    };
    use std::io::{BufRead, Write};
    let mut s = std::os::unix::net::UnixStream::connect(path).unwrap();
    let _ = s.write_all(b"{\"id\":1,\"cmd\":\"status\"}\n");
    let mut line = String::new();
    let _ = std::io::BufReader::new(s).read_line(&mut line);
    print!("REPLY:{line}");
}

#[tokio::test]
async fn foreign_uid_is_refused() {
    // SAFETY: no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        eprintln!("skipped: needs root to run a child under another uid");
        return;
    }
    let (dir, path, _tx) = start(ServerLimits::default()).await;
    // Let the foreign user reach the socket file so that only SO_PEERCRED can refuse it.
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
    std::fs::set_permissions(
        path.parent().unwrap(),
        std::fs::Permissions::from_mode(0o777),
    )
    .unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o666)).unwrap();
    let exe = std::env::current_exe().unwrap();
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new(exe)
            .args([
                "--exact",
                "foreign_peer_child",
                "--ignored",
                "--nocapture",
                "--test-threads=1",
            ])
            .env(PEER_ENV, &path)
            .uid(65534)
            .gid(65534)
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let reply = stdout
        .split("REPLY:")
        .nth(1)
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(reply.contains("permission denied"), "{reply}");
    assert!(!reply.contains("\"ok\":true"), "{reply}");
}
