#!/usr/bin/env bash
# Run every test (unit, in-process node tests, system tests with real processes, bag replays) in the repo's
# venv of locked versions, created/refreshed first. Extra arguments go to pytest.
#   scripts/test.sh --latest [pytest args]   the drift run: the same tests against the newest versions
#                                            setup.py allows, in a venv of its own (.venv-latest)
set -euo pipefail
latest=false
if [ "${1:-}" = --latest ]; then latest=true; shift; fi
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
exec "$python" -m pytest -q "$@"
