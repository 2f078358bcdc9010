#!/usr/bin/env bash
# Run every test (unit, in-process node tests, system tests with real processes, bag replays) in the repo's
# venv of locked versions, created/refreshed first. Extra arguments go to pytest.
#   scripts/test.sh [pytest options]         the whole suite, then the unit level again as on another CPU; the
#                                            unit level (computation, no ROS) on one worker per core, the ROS
#                                            levels on two (pytest-xdist)
#   scripts/test.sh PATHS, -k EXPR, -m EXPR  only what is selected, once (any argument not starting with '-')
#   scripts/test.sh --other-cpu [args]       only as on another CPU (test/unit unless paths are given)
#   scripts/test.sh --latest [args]          the drift run: the same tests against the newest versions
#                                            setup.py allows, in a venv of its own (.venv-latest)
# "As on another CPU": OpenBLAS takes the Prescott kernels (SSE3: every x86-64 CPU runs them, and they sum in
# other orders than an AVX2 or AVX-512 host's) and numba compiles for a generic x86-64 CPU (a cache entry of
# its own beside the host's: the first such run compiles the kernels once). A test whose expected value
# depends on the host's kernels fails on the development machine too. The main run keeps the environment's
# own OPENBLAS_CORETYPE and NUMBA_CPU_NAME.
set -euo pipefail
latest=false
other_cpu=false
if [ "${1:-}" = --latest ]; then latest=true; shift; fi
if [ "${1:-}" = --other-cpu ]; then other_cpu=true; shift; fi
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
selects=false
quiet=-q  # pytest's -q, unless the caller sets the verbosity (a second -q would hide the summary line)
for arg in "$@"; do
    case "$arg" in -q*|-v*|--quiet|--verbose) quiet=--verbosity=0 ;; -*) ;; *) selects=true ;; esac
done
# not again as on another CPU: mypy, ruff and the import rules (no arithmetic in them); the machine-independence
# probes (they set the kernels of each child process themselves)
host_only=(--ignore=test/unit/test_static.py --ignore=test/unit/planning/test_machine_independence.py)
# test/unit on one process per core, a test module per process (its module fixtures made once); up to 4 processes
workers=(-n auto --maxprocesses=4 --dist loadfile)
# test/ros and test/system on up to 2: a test and its node processes seldom fill two cores (they wait on discovery
# and on recorded paces), and each test claims a ROS domain of its own; then, alone, the tests marked wall_clock
# (a loop on wall-clock timers compared with a recorded or simulated one: setup.cfg)
ros_workers=(-n auto --maxprocesses=2 --dist loadfile)
as_on_another_cpu() {
    if [ "$(uname -m)" != x86_64 ]; then
        echo "scripts/test.sh: not an x86-64 machine: the run as on another CPU is skipped" >&2
        return 0
    fi
    echo "as on another CPU (OPENBLAS_CORETYPE=Prescott NUMBA_CPU_NAME=generic): $*"
    OPENBLAS_CORETYPE=Prescott NUMBA_CPU_NAME=generic "$python" -m pytest "$quiet" "$@"
}
if [ "$other_cpu" = true ]; then
    if [ "$selects" = true ]; then
        as_on_another_cpu "$@"
    else
        as_on_another_cpu "${workers[@]}" "$@" test/unit "${host_only[@]}"
    fi
    exit
fi
if [ "$selects" = true ]; then exec "$python" -m pytest "$quiet" "$@"; fi
status=0
"$python" -m pytest "$quiet" "${workers[@]}" "$@" test/unit || status=$?
"$python" -m pytest "$quiet" "${ros_workers[@]}" "$@" test --ignore=test/unit -m "not wall_clock" || status=$?
"$python" -m pytest "$quiet" "$@" test --ignore=test/unit -m wall_clock || status=$?
as_on_another_cpu "${workers[@]}" "$@" test/unit "${host_only[@]}" || status=$?
exit "$status"
