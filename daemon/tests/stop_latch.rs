//! The operator's stop reaches the loop outside the request queue (issue 20 item 6: a stop path
//! no other client can occupy). With the queue full of other requests the stop is latched in the
//! next cycle, and a resume never releases a stop requested after the resume was sent, whatever
//! the queue does to the resume (rig: `cycle_rig`).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod cycle_rig;

use cycle_rig::*;
use fri_service::service::cycle::StopLatch;
use proptest::prelude::*;
use proptest::strategy::Strategy as _;

fn latch(rig: &Rig) -> StopLatch {
    rig.client.responder.hook().stop_latch()
}

/// Fills the request queue with harmless requests (arming an armed monitor); returns how many
/// it took.
fn fill_queue(rig: &Rig, at_most: usize) -> usize {
    (0..at_most)
        .take_while(|_| rig.requests.try_send(CycleRequest::Arm(true)).is_ok())
        .count()
}

#[test]
fn a_stop_is_latched_in_the_next_cycle_with_the_request_queue_full() {
    let mut rig = warm_rig(sim_config(41));
    let target = rig.target([0.0, 0.3, 0.0, -0.3, 0.0, 0.0, 0.0]);
    rig.start_move(target);
    rig.run(100);
    assert!(rig.moving());
    // A flood of other requests: the queue takes no more (a stop through it would be refused
    // with `busy`, or wait behind eight requests per cycle).
    fill_queue(&rig, usize::MAX);
    assert!(rig.requests.try_send(CycleRequest::Stop).is_err());
    latch(&rig).request();
    rig.cycle();
    assert_eq!(rig.stops(), [StopReason::Operator]);
    assert!(rig.has(flags::STOPPED));
    assert!(rig.run_until(MAX_WAIT, |r| !r.moving() && r.at_rest()));
    assert!(rig.has(flags::STOPPED));
}

#[test]
fn a_resume_queued_before_a_stop_does_not_release_it() {
    let mut rig = warm_rig(sim_config(42));
    let latch = latch(&rig);
    latch.request();
    rig.cycle();
    assert!(rig.has(flags::STOPPED));
    // The operator resumes (stamped with the one stop so far), but the resume waits in a full
    // queue; meanwhile another stop is requested.
    fill_queue(&rig, 63);
    rig.send(CycleRequest::Resume {
        after_stops: latch.requested(),
    });
    latch.request();
    rig.run(200);
    assert!(rig.has(flags::STOPPED), "a later stop was released");
    assert_eq!(rig.resumes(), 0);
    // A resume sent now releases it.
    rig.send(CycleRequest::Resume {
        after_stops: latch.requested(),
    });
    rig.cycle();
    assert!(!rig.has(flags::STOPPED));
    assert_eq!(rig.resumes(), 1);
}

/// What an operator (or a flood) does between two looks at the arm.
#[derive(Debug, Clone)]
enum Op {
    /// `stop`: through the latch.
    Stop,
    /// `resume`: into the queue, stamped with the stops requested when it is sent.
    Resume,
    /// Other clients' requests fill the queue (up to this many).
    Flood(usize),
    /// The loop runs this many cycles.
    Run(usize),
}

fn op() -> impl proptest::strategy::Strategy<Value = Op> {
    prop_oneof![
        2 => Just(Op::Stop),
        2 => Just(Op::Resume),
        1 => (1usize..80).prop_map(Op::Flood),
        3 => (1usize..40).prop_map(Op::Run),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Whatever the order of stops, resumes, floods of the queue and cycles: a stop holds the
    /// arm from the next cycle on, and once every request is handled the arm is held exactly
    /// when the last of the operator's stop and resume (in the order they were issued) was a
    /// stop.
    #[test]
    fn a_stop_holds_from_the_next_cycle_and_only_a_later_resume_releases_it(
        ops in prop::collection::vec(op(), 1..40),
    ) {
        let mut rig = warm_rig(sim_config(43));
        let latch = latch(&rig);
        let mut last_was_stop = false;
        for op in ops {
            match op {
                Op::Stop => {
                    latch.request();
                    last_was_stop = true;
                    rig.cycle();
                    prop_assert!(rig.has(flags::STOPPED), "not held in the cycle after a stop");
                }
                Op::Resume => {
                    // A resume the full queue refuses was never issued (the operator gets `busy`).
                    let resume = CycleRequest::Resume { after_stops: latch.requested() };
                    if rig.requests.try_send(resume).is_ok() {
                        last_was_stop = false;
                    }
                }
                Op::Flood(n) => {
                    fill_queue(&rig, n);
                }
                Op::Run(n) => rig.run(n),
            }
        }
        // 64 queued requests take 8 cycles.
        rig.run(20);
        prop_assert_eq!(rig.has(flags::STOPPED), last_was_stop);
    }
}
