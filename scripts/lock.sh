#!/usr/bin/env bash
# Refresh the version lock: requirements/lock.txt (every package setup.py asks for, with all its extras, and
# what they need, with the hashes of each version's files on PyPI) and requirements/uv.txt (the installer).
#
#   scripts/lock.sh                          re-resolve, keeping every pin that still satisfies setup.py
#   scripts/lock.sh --upgrade                move every pin to the newest version setup.py allows
#   scripts/lock.sh --upgrade-package NAME   move one package (repeatable)
#
# Then run ./scripts/test.sh (it installs the new lock into .venv) and commit both files if it passes.
# The resolution is universal: one version per package for every platform and every Python >= 3.11 (the
# fewest versions that can), so the lock does not depend on the machine that made it.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tools="$(mktemp -d)"
trap 'rm -rf "$tools"' EXIT
"${PYTHON:-python3}" -m venv "$tools/venv"
"$tools/venv/bin/python" -m pip install -q --require-hashes --no-deps -r "$repo/requirements/uv.txt"
uv="$tools/venv/bin/uv"
options=(--universal --python-version 3.11 --fork-strategy fewest --generate-hashes --quiet
         --custom-compile-command scripts/lock.sh)
cd "$repo"
"$uv" pip compile setup.py --all-extras "${options[@]}" "$@" -o requirements/lock.txt
echo "uv==$("$uv" --version | cut -d' ' -f2)" | "$uv" pip compile - "${options[@]}" -o requirements/uv.txt
