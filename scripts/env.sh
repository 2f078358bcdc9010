# Sourced by demo.sh and test.sh: create/refresh the repo's venv (.venv-latest instead when the caller set
# latest=true: the drift run), set the ROS network environment, cd to the repository. Sets $repo and $python.
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ "${latest:-false}" = true ]; then
    bash "$repo/scripts/venv.sh" --latest
    python="$repo/.venv-latest/bin/python"
    export GRASP_INTENT_ROS_UNLOCKED=1  # test/unit/test_lock.py: this venv is not the lock's, on purpose
else
    bash "$repo/scripts/venv.sh"
    python="$repo/.venv/bin/python"
fi
# Network rule: ROS traffic stays on loopback. The domain id is chosen by the Python side
# (grasp_intent_ros.launch.suite.domain_id_from_environment: ROS_DOMAIN_ID if set, else one of its own;
# the tests claim one per test).
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
cd "$repo"
