#!/usr/bin/env bash
# Side-by-side timing of the `dynamics` crate against Pinocchio's C++ on the same machine: builds
# the Rust side (dynamics/examples/bench_vs_pinocchio.rs) and the C++ harness
# (tools/pinocchio_bench), checks that both compute the same M(q), C(q, q̇), τ and g (max relative
# difference ≤ 1e-12), then alternates Rust and C++ runs for ROUNDS rounds and prints, per round and
# as the median over rounds, the ratios Rust / Pinocchio of the per-call minimum and median times.
#
# Usage: tools/bench_vs_pinocchio.sh [ROUNDS]          (default 5)
# Environment:
#   PIN_VENV       venv with `pip install pin cmeel-eigen` (default /work/venv-pin)
#   PIN_BENCH      the C++ harness binary (default target/pinocchio_bench, built if missing or stale)
#   RUST_BASELINE  optional second Rust binary of the same example (e.g. an older build), run in the
#                  same rounds and reported as "baseline"
set -euo pipefail

rounds="${1:-5}"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
golden="$root/../shared/data/lwr4-golden.json"
[[ -f "$golden" ]] || golden="$root/dynamics/tests/fixtures/lwr4-golden.json"
cpp="${PIN_BENCH:-$root/target/pinocchio_bench}"
rust="$root/target/release/examples/bench_vs_pinocchio"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

(cd "$root" && cargo build --release --quiet -p dynamics --example bench_vs_pinocchio)
if [[ ! -x "$cpp" || "$here/pinocchio_bench/pinocchio_bench.cpp" -nt "$cpp" ]]; then
  "$here/pinocchio_bench/build.sh" "${PIN_VENV:-/work/venv-pin}" "$cpp"
fi

"$rust" --values >"$out/rust.values"
"$cpp" "$golden" --values >"$out/cpp.values"

for r in $(seq 1 "$rounds"); do
  if [[ -n "${RUST_BASELINE:-}" ]]; then
    "$RUST_BASELINE" | sed 's/^rust /baseline /' >"$out/baseline.$r"
  fi
  "$rust" >"$out/rust.$r"
  "$cpp" "$golden" >"$out/cpp.$r"
  echo "round $r/$rounds done (load average $(cut -d' ' -f1-3 /proc/loadavg))" >&2
done

python3 - "$out" "$rounds" <<'PY'
import os, statistics, sys

out, rounds = sys.argv[1], int(sys.argv[2])

def values(path):
    table = {}
    for line in open(path):
        name, _row, *numbers = line.split()
        table.setdefault(name, []).append([float(x) for x in numbers])
    return table

def relative(a, b):
    scale = max(abs(x) for row in b for x in row)
    return max(abs(x - y) for ra, rb in zip(a, b) for x, y in zip(ra, rb)) / scale

rust_v, cpp_v = values(f"{out}/rust.values"), values(f"{out}/cpp.values")
worst = 0.0
for ours, theirs in [("M", "M_A"), ("M", "M_B"), ("C", "C_A"), ("C", "C_B"),
                     ("tau", "tau_A"), ("g", "g_A")]:
    d = relative(rust_v[ours], cpp_v[theirs])
    worst = max(worst, d)
    print(f"same work: {ours:3s} vs Pinocchio {theirs:5s} max relative difference {d:.1e}")
if worst > 1e-12:
    sys.exit(f"outputs differ by {worst:e} > 1e-12: not the same computation")

def timings(path):
    rows = {}
    for line in open(path):
        if line.startswith("#"):
            continue
        side, name, median, minimum = line.split()
        rows[name] = (float(median), float(minimum))
    return rows

comparisons = [
    ("crba", "crba/A"), ("crba", "crba/B"),
    ("crba", "crba_symmetrised/A"), ("crba", "crba_symmetrised/B"),
    ("crba", "crba_world/A"), ("crba", "crba_world/B"),
    ("coriolis_matrix", "coriolis_matrix/A"), ("coriolis_matrix", "coriolis_matrix/B"),
    ("rnea", "rnea/A"), ("rnea", "rnea/B"),
    ("gravity", "gravity/A"), ("gravity", "gravity/B"),
]
sides = ["rust"] + (["baseline"] if os.path.exists(f"{out}/baseline.1") else [])
ratios = {}
print()
print("ns per call (min | median over 300 batches of 2000); ratio = Rust / Pinocchio")
for r in range(1, rounds + 1):
    cpp = timings(f"{out}/cpp.{r}")
    for side in sides:
        ours = timings(f"{out}/{side}.{r}")
        for name, theirs in comparisons:
            (om, on), (pm, pn) = ours[name], cpp[theirs]
            ratios.setdefault((side, name, theirs), []).append((on / pn, om / pm, on, om, pn, pm))
print(f"{'side':8s} {'ours':16s} {'Pinocchio':20s} {'per-round ratio of minima':>34s}   "
      f"{'median ratio (min)':>18s} {'median ratio (median)':>21s}  ours min/med  Pin min/med")
for (side, name, theirs), rs in ratios.items():
    per_round = " ".join(f"{x[0]:.2f}" for x in rs)
    print(f"{side:8s} {name:16s} {theirs:20s} {per_round:>34s}   "
          f"{statistics.median(x[0] for x in rs):18.2f} {statistics.median(x[1] for x in rs):21.2f}"
          f"  {statistics.median(x[2] for x in rs):5.0f}/{statistics.median(x[3] for x in rs):<5.0f}"
          f"  {statistics.median(x[4] for x in rs):5.0f}/{statistics.median(x[5] for x in rs):<5.0f}")
PY
