#!/usr/bin/env bash
# Builds the Pinocchio C++ yardstick (tools/pinocchio_bench/pinocchio_bench.cpp) against the
# headers that `pip install pin cmeel-eigen` puts into a Python venv's cmeel prefix. Header-only
# use: every Pinocchio algorithm is instantiated in the harness and compiled with the flags below.
#
# Usage: tools/pinocchio_bench/build.sh [VENV] [OUTPUT]
#   VENV    the venv holding pin and cmeel-eigen (default: $PIN_VENV or /work/venv-pin); make it with
#           python3 -m venv /work/venv-pin && /work/venv-pin/bin/pip install pin==4.1.0 cmeel-eigen==3.4.1
#   OUTPUT  the binary (default: target/pinocchio_bench in the repository root)
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="${1:-${PIN_VENV:-/work/venv-pin}}"
out="${2:-$root/target/pinocchio_bench}"

prefix="$(ls -d "$venv"/lib/python3*/site-packages/cmeel.prefix 2>/dev/null | head -n 1 || true)"
if [[ -z "$prefix" || ! -f "$prefix/include/pinocchio/config.hpp" ]]; then
  echo "error: no Pinocchio headers under $venv/lib/python3*/site-packages/cmeel.prefix" >&2
  echo "       (pip install pin cmeel-eigen into that venv first)" >&2
  exit 1
fi
for header in "$prefix/include/eigen3/Eigen/Core" "$prefix/include/boost/variant.hpp"; do
  if [[ ! -f "$header" ]]; then
    echo "error: $header missing (cmeel-eigen / cmeel-boost not installed in $venv?)" >&2
    exit 1
  fi
done

mkdir -p "$(dirname "$out")"
# The definitions are those of pinocchio::pinocchio_headers (lib/cmake/pinocchio/pinocchioTargets.cmake).
g++ -std=c++17 -O3 -march=native -DNDEBUG \
  -DBOOST_MPL_LIMIT_LIST_SIZE=30 -DBOOST_MPL_LIMIT_VECTOR_SIZE=30 \
  -DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS -DBOOST_FUSION_INVOKE_MAX_ARITY=12 \
  -isystem "$prefix/include" -isystem "$prefix/include/eigen3" \
  "$here/pinocchio_bench.cpp" -o "$out"
echo "built $out (pinocchio $(grep -m1 'define PINOCCHIO_VERSION ' "$prefix/include/pinocchio/config.hpp" | cut -d'"' -f2))"
