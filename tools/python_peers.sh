#!/usr/bin/env bash
# Creates the virtual environment of the Python peers (DDS, MCAP reader) the ROS 2 tests run
# (target/python-peers, from tools/python-peers.txt). The tests create it themselves when it is
# missing; .ci/run calls this first so the download happens outside the test timeouts.
# Usage: tools/python_peers.sh [VENV_DIR]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="${1:-$root/target/python-peers}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$root/tools/python-peers.txt"
"$venv/bin/python" -c 'import cyclonedds, mcap, mcap_ros2.decoder, importlib.metadata as m; print(*(f"{p} {m.version(p)}" for p in ("cyclonedds", "mcap", "mcap-ros2-support")))'
