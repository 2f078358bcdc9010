#!/usr/bin/env bash
# Create (or refresh) a venv of the repository and install the package into it.
#
#   scripts/venv.sh            .venv: exactly the locked versions of requirements/lock.txt (hashes checked),
#                              then the package itself, editable
#   scripts/venv.sh --latest   .venv-latest: the newest versions setup.py allows (the drift run), and a list
#                              of what differs from the lock
#
# Safe to run twice: .venv is installed again only when requirements/, setup.py, package.xml or this script
# changed. The installer is uv, itself pinned with hashes in requirements/uv.txt and installed by pip.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
py="${PYTHON:-python3}"
latest=false
[ "${1:-}" = --latest ] && latest=true
venv="$repo/.venv"
$latest && venv="$repo/.venv-latest"

if ! "$py" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
    echo "$py is Python $("$py" -c 'import platform; print(platform.python_version())'); the locked venv needs" \
         "3.11 or newer: PYTHON=python3.12 $0" >&2
    exit 1
fi
[ -x "$venv/bin/python" ] || "$py" -m venv "$venv"
uv="$venv/bin/uv"
want="$(cat "$repo"/requirements/*.txt "$repo/setup.py" "$repo/package.xml" "${BASH_SOURCE[0]}" | sha256sum | cut -d' ' -f1)"
stamp="$venv/.installed"
if $latest || [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    log="$venv/install.log"
    echo "installing grasp_intent_ros and its dependencies into $venv (log: $log)" >&2
    {
        "$venv/bin/python" -m pip install --require-hashes --no-deps -r "$repo/requirements/uv.txt"
        if $latest; then
            "$uv" pip install --python "$venv/bin/python" --compile-bytecode --upgrade -r "$repo/setup.py" \
                --all-extras
        else  # install, not sync: the ROS wheels bring distributions of their own (rclpy, std_msgs, ...) that
            # no lock names, and a sync would remove them as extraneous
            "$uv" pip install --python "$venv/bin/python" --compile-bytecode --require-hashes --no-deps \
                -r "$repo/requirements/lock.txt"
        fi
        # the package itself, its metadata built afresh each time (its entry points follow setup.py)
        "$uv" pip install --python "$venv/bin/python" --no-deps --no-build-isolation --reinstall --no-cache \
            -e "$repo"
    } >"$log" 2>&1 || { tail -n 40 "$log" >&2; echo "install failed; full log: $log" >&2; exit 1; }
    echo "$want" > "$stamp"
fi
if $latest; then  # what the drift run tests beyond the lock: each locked package whose version moved
    pins() { awk -F'==' '{n = tolower($1); gsub(/[-_.]+/, "-", n); print n "=" $2}' | sort -t= -k1,1; }
    echo "moved since the lock (locked -> installed in $venv):" >&2
    join -t= <(grep -E '^[A-Za-z0-9]' "$repo/requirements/lock.txt" | cut -d' ' -f1 | pins) \
             <("$uv" pip freeze --quiet --python "$venv/bin/python" --exclude-editable | pins) \
        | awk -F= '$2 != $3 {print "  " $1 " " $2 " -> " $3; n++} END {if (!n) print "  nothing"}' >&2
fi
# Compile the planner's numba kernels now (cached next to the source; a no-op when the cache is fresh),
# so that no node pays for compilation on its first plan.
"$venv/bin/python" -m grasp_intent_ros.kernels
# Byte-compile the package's own modules (an editable install leaves them to the first import, which writes
# nothing under PYTHONDONTWRITEBYTECODE=1, and each node process would compile them again).
"$venv/bin/python" -m compileall -q "$repo/grasp_intent_ros"
