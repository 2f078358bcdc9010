#!/usr/bin/env bash
# Create (or refresh) the repository's venv in .venv and install the package with its extras.
# Idempotent: a second run reuses the venv and only installs what changed.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
py="${PYTHON:-python3}"
if [ ! -x "$repo/.venv/bin/python" ]; then
    "$py" -m venv "$repo/.venv"
fi
stamp="$repo/.venv/.installed"
want="$(cat "$repo/setup.py" "$repo/package.xml" | sha256sum | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    "$repo/.venv/bin/python" -m pip install --quiet --upgrade pip >/dev/null
    "$repo/.venv/bin/python" -m pip install --quiet -e "$repo[ros,test]"
    echo "$want" > "$stamp"
fi
