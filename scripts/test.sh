#!/usr/bin/env bash
# Run every test (unit, in-process node tests, system tests with real processes, bag replays).
# Creates/refreshes the repo's venv first. Extra arguments go to pytest.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
exec "$python" -m pytest -q "$@"
