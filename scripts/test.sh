#!/usr/bin/env bash
# Run every test (unit, in-process node tests, system tests with real processes, bag replays).
# Creates/refreshes the repo's venv first. Extra arguments go to pytest.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/venv.sh"
# Network rule: ROS traffic stays on loopback. Each test picks its own ROS_DOMAIN_ID on top of this.
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( (($$ % 80)) + 10 ))}"
cd "$repo"
exec "$repo/.venv/bin/python" -m pytest -q "$@"
