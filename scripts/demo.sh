#!/usr/bin/env bash
# The main job: creates/refreshes the repo's venv, then runs the demo (python -m grasp_intent_ros.demo): the
# three nodes as separate processes, the paper's intent cases through them, a clean shutdown.
# Extra arguments go to the demo (--models-dir DIR, --timeout S).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/venv.sh"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( (($$ % 80)) + 10 ))}"
cd "$repo"
exec "$repo/.venv/bin/python" -m grasp_intent_ros.demo "$@"
