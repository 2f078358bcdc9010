# Sourced by demo.sh and test.sh: create/refresh the repo's venv, set the ROS network environment, cd
# to the repository. Sets $repo and $python.
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/venv.sh"
# Network rule: ROS traffic stays on loopback, on a domain of our own (tests pick theirs per test).
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( ($$ % 80) + 10 ))}"
python="$repo/.venv/bin/python"
cd "$repo"
