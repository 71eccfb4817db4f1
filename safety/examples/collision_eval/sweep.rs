//! `--sweep`: the tuning sweep of observer gain, velocity filter and debounce.

use std::fmt::Write as _;

use safety::VelocityFilter;

use crate::args::Args;
use crate::campaign::{FIFTY_NEWTON, fifty_newton_campaign};
use crate::fig6::fig6_detection;
use crate::free_motion::{free_motion, free_motion_table};
use crate::report::summarise_campaign;
use crate::variant::candidate;

/// Tuning sweep for the delay targets: every candidate on the full free-motion campaign
/// (`hours`), the 20 ms and 10 ms 50 N campaigns on links 4–7 and the Fig. 6 experiment.
pub fn sweep(args: &Args) {
    let started = std::time::Instant::now();
    let first = |hz: f64| VelocityFilter::FirstOrder { cutoff_hz: hz };
    let variants = vec![
        candidate(100.0, first(200.0), 2),
        candidate(400.0, first(200.0), 1),
        candidate(500.0, first(200.0), 1),
        candidate(600.0, first(200.0), 1),
        candidate(500.0, first(300.0), 1),
        candidate(500.0, first(400.0), 2),
        candidate(700.0, first(200.0), 2),
    ];
    let mut report = String::new();
    writeln!(
        report,
        "## collision_eval --sweep (seed {}, θ = 6 Nm, exact ZOH)\n",
        args.seed
    )
    .unwrap();
    fig6_detection(args.seed, &variants, &mut report);
    eprintln!("fig6 done after {:.0} s", started.elapsed().as_secs_f64());
    let free_runs = free_motion(args.seed, args.hours, &variants);
    writeln!(
        report,
        "#### Randomised free motion ({:.2} h)\n",
        free_runs[0].hours
    )
    .unwrap();
    free_motion_table(&mut report, "false alarms", &free_runs);
    eprintln!(
        "free motion done after {:.0} s",
        started.elapsed().as_secs_f64()
    );
    for (duration, tag) in FIFTY_NEWTON {
        let cs = fifty_newton_campaign(args.seed, args.contacts, duration, &variants);
        summarise_campaign(&format!("50 N, {tag} half-sine"), &cs, false, &mut report);
        eprintln!(
            "campaign {tag} done after {:.0} s",
            started.elapsed().as_secs_f64()
        );
    }
    writeln!(
        report,
        "Wall time {:.0} s.",
        started.elapsed().as_secs_f64()
    )
    .unwrap();
    std::fs::write(args.out.join("sweep.md"), &report).unwrap();
    print!("{report}");
}
