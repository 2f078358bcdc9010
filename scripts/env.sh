# Sourced by demo.sh and test.sh: create/refresh the repo's venv, set the ROS network environment, cd
# to the repository. Sets $repo and $python.
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/venv.sh"
# Network rule: ROS traffic stays on loopback. The domain id is chosen by the Python side
# (grasp_intent_ros.tools.suite.domain_id_from_environment: ROS_DOMAIN_ID if set, else one of its own;
# the tests claim one per test).
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
python="$repo/.venv/bin/python"
cd "$repo"
