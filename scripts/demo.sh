#!/usr/bin/env bash
# The main job: creates/refreshes the repo's venv, then runs the demo. Extra arguments go to the demo.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
exec "$python" -m grasp_intent_ros demo "$@"
