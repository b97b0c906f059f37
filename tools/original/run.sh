#!/usr/bin/env bash
# Run the original CRAFT simulator once, headless.
#
# Usage: tools/original/run.sh CONTROLLER_JSON
#   CONTROLLER_JSON  the simulator's controller file (simulationID, offline, width, height,
#                    inputScenePath, outputVideoPath, outputJSONPath, stepCount, ...).
#                    Give absolute paths inside it: the simulator runs with its own folder as cwd.
# Env:   CRAFT_ORIGINAL_BIN  the built binary (default: what tools/original/build.sh prints;
#                            it builds on first use)
#        DISPLAY             an X display to use; when unset, a private Xvfb is started for this
#                            run and stopped afterwards
# Exit:  the simulator's exit status (0 on success; 255 when no display could be opened;
#        139 on an unreadable controller file; 1 when the video file cannot be written).
#        Its stdout (progress lines and the causal graph as DOT) and stderr pass through.
set -euo pipefail

die() {
    echo "run.sh: error: $*" >&2
    exit 2
}

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
(($# == 1)) || die "usage: $0 CONTROLLER_JSON"
[[ -f "$1" ]] || die "controller file not found: $1"
controller="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"

binary="${CRAFT_ORIGINAL_BIN:-}"
if [[ -z "$binary" ]]; then
    binary="$("$here/build.sh" | tail -n 1)" || die "build failed"
fi
[[ -x "$binary" ]] || die "simulator binary not found or not executable: $binary"
workdir="$(dirname "$binary")"
[[ -f "$workdir/Data/Textures/eyes.png" ]] || die "no Data/ folder beside $binary"

xvfb_pid=""
tmp=""
cleanup() {
    if [[ -n "$xvfb_pid" ]]; then
        kill "$xvfb_pid" 2>/dev/null || true
        wait "$xvfb_pid" 2>/dev/null || true
    fi
    if [[ -n "$tmp" ]]; then
        rm -rf "$tmp"
    fi
}
trap cleanup EXIT

if [[ -z "${DISPLAY:-}" ]]; then
    command -v Xvfb >/dev/null 2>&1 || die "Xvfb not found (apt-get install xvfb) and DISPLAY is unset"
    tmp="$(mktemp -d -t craft-xvfb.XXXXXX)"
    mkfifo "$tmp/displayfd"
    # -displayfd: Xvfb picks a free display number and writes it once it accepts clients.
    Xvfb -displayfd 3 -screen 0 1024x768x24 -nolisten tcp 3>"$tmp/displayfd" 2>"$tmp/xvfb.log" &
    xvfb_pid=$!
    display_number=""
    read -r -t 30 display_number <"$tmp/displayfd" || true
    if [[ -z "$display_number" ]]; then
        cat "$tmp/xvfb.log" >&2 || true
        die "Xvfb did not start"
    fi
    export DISPLAY=":$display_number"
fi

status=0
(cd "$workdir" && "$binary" "$controller") || status=$?
exit "$status"
