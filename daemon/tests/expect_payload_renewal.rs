//! Issue 34 item 1, at the operator socket of the whole daemon in-process: `expect-payload`
//! while the payload is declared unknown is refused with its typed cause (the grasp window,
//! the pin and the expiry stay), and `--end` followed by a new declaration opens a grasp window
//! at most `MAX_DECLARATIONS_WITHOUT_PAYLOAD` times until a payload with mass is applied.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use fri_api::cause::Cause;
use fri_api::client::Client;
use fri_api::protocol::{Command, ErrorCode, OperatorError};
use fri_service::service::workflow::expect_payload::MAX_DECLARATIONS_WITHOUT_PAYLOAD;
use fri_service::testkit::{InProcess, local_config};

fn declare() -> Command {
    Command::ExpectPayload {
        max_mass: None,
        max_radius: None,
        end: None,
    }
}

fn end() -> Command {
    Command::ExpectPayload {
        max_mass: None,
        max_radius: None,
        end: Some(true),
    }
}

async fn call(c: &mut Client, cmd: Command) -> Result<serde_json::Value, OperatorError> {
    c.call(cmd, |_, _| {}).await.unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_renewed_declaration_is_refused_and_end_and_declare_is_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(local_config(dir.path(), "renewal"))
        .await
        .unwrap();
    let mut c = h.client().await.unwrap();
    call(&mut c, declare()).await.unwrap();
    // Repeated while active (the attack, every ~6.5 s): refused each time, typed.
    for _ in 0..3 {
        let e = call(&mut c, declare()).await.unwrap_err();
        assert_eq!(e.code, ErrorCode::NotReady, "{e:?}");
        assert!(
            matches!(
                e.cause.as_deref(),
                Some(Cause::AlreadyDeclared { declaration: 1, .. })
            ),
            "{e:?}"
        );
        assert!(e.message.contains("grasp window"), "{e:?}");
    }
    // --end and a new declaration: as many grasp windows as the bound, then refused.
    for _ in 1..MAX_DECLARATIONS_WITHOUT_PAYLOAD {
        call(&mut c, end()).await.unwrap();
        call(&mut c, declare()).await.unwrap();
    }
    call(&mut c, end()).await.unwrap();
    let e = call(&mut c, declare()).await.unwrap_err();
    assert_eq!(
        e.cause.as_deref(),
        Some(&Cause::DeclarationsExhausted {
            declarations: MAX_DECLARATIONS_WITHOUT_PAYLOAD,
            max: MAX_DECLARATIONS_WITHOUT_PAYLOAD,
        }),
        "{e:?}"
    );
    // Clearing the payload (none: nothing is known of the load) does not reset the count.
    call(&mut c, Command::ClearPayload).await.unwrap();
    assert!(call(&mut c, declare()).await.is_err());
    // A payload with mass does: the next grasp may be declared.
    call(
        &mut c,
        Command::ApplyPayload {
            mass: 1.5,
            com: [0.0, 0.0, 0.1],
            // No controller to check against: the count's reset is under test.
            force: Some(true),
        },
    )
    .await
    .unwrap();
    call(&mut c, declare()).await.unwrap();
    h.stop().await.unwrap();
}
