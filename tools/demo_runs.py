#!/usr/bin/env python3
"""Runs the README demo (`fri-demo demo --json`, real time) N times and counts passes.

A run passes when it exits 0, detects all three contacts with the payload-compensated residual
and raises no compensated false alarm. With --busy K, K busy loops (`sh -c 'while :; do :; done'`)
load the cores for the whole series. Prints one line per run and a summary line
`N passed, M failed`.

    cargo build --release -p fri-demo
    python3 tools/demo_runs.py --runs 20             # idle
    python3 tools/demo_runs.py --runs 20 --busy 2    # both cores busy
    python3 tools/demo_runs.py --runs 50 --lockstep  # the controller in lockstep, seeds 1-50
"""
import argparse
import json
import subprocess
import sys
import tempfile


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=20, help="number of demo runs (1..1000)")
    ap.add_argument("--busy", type=int, default=0, help="busy loops running meanwhile (0..16)")
    ap.add_argument("--binary", default="target/release/fri-demo")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--lockstep", action="store_true", help="the simulated controller in lockstep")
    args = ap.parse_args()
    if not 1 <= args.runs <= 1000:
        ap.error(f"--runs {args.runs} is outside 1..1000")
    if not 0 <= args.busy <= 16:
        ap.error(f"--busy {args.busy} is outside 0..16")
    loops = [subprocess.Popen(["sh", "-c", "while :; do :; done"]) for _ in range(args.busy)]
    passed = failed = 0
    try:
        for k in range(args.runs):
            seed = args.first_seed + k
            with tempfile.TemporaryDirectory() as out:
                p = subprocess.run(
                    [args.binary, "demo", "--json", "--seed", str(seed), "--out", out]
                    + (["--lockstep"] if args.lockstep else []),
                    capture_output=True, text=True, timeout=600,
                )
            verdict, why = False, f"exit {p.returncode}: {p.stderr.strip().splitlines()[-1:] }"
            if p.returncode == 0:
                try:
                    r = json.loads(p.stdout.strip().splitlines()[-1])
                    det = r["detections_compensated"]
                    fa = r["false_alarms_compensated"]
                    verdict = len(det) == 3 and fa == 0
                    why = f"mass {r['payload_estimate']['mass']:.4f} kg, detections {det}, false alarms {fa}"
                except (ValueError, KeyError, IndexError) as e:
                    why = f"unreadable report: {e}"
            passed += verdict
            failed += not verdict
            print(f"run {k + 1} seed {seed}: {'pass' if verdict else 'FAIL'} ({why})", flush=True)
    finally:
        for l in loops:
            l.kill()
    print(f"{passed} passed, {failed} failed")
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
