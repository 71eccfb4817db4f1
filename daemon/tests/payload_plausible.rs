//! Issue 34, item 5: `apply-payload` checks the declared payload against the static torques
//! the controller measures at rest, through the whole daemon in-process against the mock robot
//! in lockstep carrying the paper's 3.028 kg. The attack (3.9 kg declared) is refused
//! with both figures; `force` applies it and the audit trail records it as weakening, every
//! time; the true payload is applied; a moving arm refuses the check naming the joint; a tare
//! at the pose is the baseline when there is one.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::time::Duration;

use common::*;
use fri_api::cause::Cause;
use fri_api::protocol::{Command, ErrorCode, OperatorError, RecordKind};
use fri_api::results::{PayloadBaseline, PayloadRefusal, PayloadResult};
use mock_robot::ServerConfig;

const TRUE_MASS: f64 = 3.028;
const TRUE_COM: [f64; 3] = [0.0, 0.0, 0.119];

fn apply(mass: f64, force: bool) -> Command {
    Command::ApplyPayload {
        mass,
        com: TRUE_COM,
        force: force.then_some(true),
    }
}

async fn typed(
    c: &mut fri_api::client::Client,
    cmd: Command,
) -> Result<PayloadResult, OperatorError> {
    call(c, cmd)
        .await
        .map(|v| serde_json::from_value(v).unwrap())
}

fn refusal(e: &OperatorError) -> &PayloadRefusal {
    match e.cause.as_deref() {
        Some(Cause::PayloadImplausible { refusal }) => refusal,
        other => panic!("cause {other:?} of {e:?}"),
    }
}

fn forced_records(events: &Collected) -> Vec<serde_json::Value> {
    events
        .lock()
        .unwrap()
        .iter()
        .filter(|(e, d)| {
            e == "audit"
                && d["change"]["what"] == "payload-applied"
                && !d["change"]["forced_past"].is_null()
        })
        .map(|(_, d)| d.clone())
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wrong_payload_is_refused_with_both_figures_unless_forced_and_then_audited_as_weakening()
{
    let dir = tempfile::tempdir().unwrap();
    let mut config = test_config(dir.path());
    config.observer.armed = false;
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sim(true, 34), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    let events = collect_watch(h.client().await, None).await;

    // The attack: 3.9 kg for the true 3.028 kg.
    let e = typed(&mut c, apply(3.9, false)).await.unwrap_err();
    eprintln!("3.9 kg for 3.028 kg: {}", e.message);
    assert_eq!(e.code, ErrorCode::InvalidArguments, "{e:?}");
    let PayloadRefusal::Disagrees { comparison: cmp } = refusal(&e) else {
        panic!("{e:?}")
    };
    let j = cmp.joint - 1;
    eprintln!("figures: {cmp:?}");
    assert_eq!(cmp.baseline, PayloadBaseline::ControllerGravity, "{cmp:?}");
    assert!(
        (cmp.measured_nm[j] - cmp.predicted_nm[j]).abs() > cmp.sigmas * cmp.sigma_nm[j],
        "{cmp:?}"
    );
    assert!(
        (cmp.mass_implied_kg - TRUE_MASS).abs() < 0.1,
        "the torques imply the true mass: {cmp:?}"
    );
    for part in [
        format!("joint {}", cmp.joint),
        format!("{:.3} Nm", cmp.predicted_nm[j]),
        format!("{:.3} Nm", cmp.measured_nm[j]),
        "mass = 3.9 kg".to_owned(),
        "force".to_owned(),
    ] {
        assert!(e.message.contains(&part), "{part}: {}", e.message);
    }
    let status = call(&mut c, Command::Status).await.unwrap();
    assert!(status["payload"].is_null(), "nothing applied: {status}");

    // The true payload is applied, with the figures of its check.
    let ok = typed(&mut c, apply(TRUE_MASS, false)).await.unwrap();
    let check = ok.check.expect("checked");
    eprintln!("3.028 kg: {check:?}");
    assert!(ok.forced_past.is_none());
    assert!((0..7).all(|j| {
        (check.measured_nm[j] - check.predicted_nm[j]).abs() <= check.sigmas * check.sigma_nm[j]
    }));
    assert!(forced_records(&events).is_empty());

    // Forced, twice: applied each time, each audited as weakening with both figures.
    for n in 1..=2 {
        let forced = typed(&mut c, apply(3.9, true)).await.unwrap();
        assert_eq!(forced.payload.as_ref().unwrap().mass, 3.9);
        assert!(
            matches!(forced.forced_past, Some(PayloadRefusal::Disagrees { .. })),
            "{forced:?}"
        );
        let deadline = std::time::Instant::now() + Duration::from_secs(20);
        while forced_records(&events).len() < n {
            assert!(
                std::time::Instant::now() < deadline,
                "no audit record of forced apply {n}"
            );
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    }
    let records = forced_records(&events);
    assert_eq!(records.len(), 2, "{records:?}");
    let past = &records[0]["change"]["forced_past"];
    assert_eq!(past["refusal"], "disagrees", "{past}");
    assert!(past["comparison"]["predicted_nm"].is_array(), "{past}");
    assert!(past["comparison"]["measured_nm"].is_array(), "{past}");
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["payload"]["mass"], 3.9, "{status}");

    // Stale: the arm moves after the declaration was made at rest → refused naming the joint.
    let mut mover = h.client().await;
    let excite = tokio::spawn(async move {
        call(
            &mut mover,
            Command::Record {
                path: "excite.csv".into(),
                kind: RecordKind::Log,
                duration_s: Some(3.0),
                count: None,
                excite_deg: Some(5.0),
            },
        )
        .await
    });
    let mut moving_refusal = None;
    for _ in 0..100 {
        tokio::time::sleep(Duration::from_millis(50)).await;
        match typed(&mut c, apply(TRUE_MASS, false)).await {
            Err(e) if matches!(refusal(&e), PayloadRefusal::NotAtRest { .. }) => {
                moving_refusal = Some(e);
                break;
            }
            _ => continue,
        }
    }
    let e = moving_refusal.expect("a moving arm refuses the check");
    eprintln!("moving: {}", e.message);
    assert_eq!(e.code, ErrorCode::NotReady);
    assert!(e.message.contains("not at rest: joint"), "{}", e.message);
    let _ = excite.await;
    drop(c);
    drop(driver);
    h.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_tare_at_the_pose_is_the_baseline() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = test_config(dir.path());
    config.observer.armed = false;
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sim(false, 35), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    call(&mut c, six_pose_tare()).await.unwrap();
    let driver = attach_payload(driver, &h, true).await;
    // The grasp rings the arm: the check waits for no one, it refuses until the arm rests.
    let mut e = None;
    for _ in 0..100 {
        let r = typed(&mut c, apply(3.9, false)).await.unwrap_err();
        if !matches!(refusal(&r), PayloadRefusal::NotAtRest { .. }) {
            e = Some(r);
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let e = e.expect("the arm comes to rest");
    eprintln!("against the tare, 3.9 kg for 3.028 kg: {}", e.message);
    let PayloadRefusal::Disagrees { comparison: cmp } = refusal(&e) else {
        panic!("{e:?}")
    };
    assert_eq!(cmp.baseline, PayloadBaseline::Tare, "{cmp:?}");
    let ok = typed(&mut c, apply(TRUE_MASS, false)).await.unwrap();
    let check = ok.check.unwrap();
    eprintln!("against the tare, 3.028 kg: {check:?}");
    assert_eq!(check.baseline, PayloadBaseline::Tare);
    assert!(
        (check.mass_implied_kg - TRUE_MASS).abs() < 0.05,
        "{check:?}"
    );
    drop(c);
    drop(driver.join());
    h.stop().await;
}
