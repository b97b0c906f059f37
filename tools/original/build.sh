#!/usr/bin/env bash
# Build the original CRAFT simulator (CRAFT-Box2D "Testbed") headless-ready on Debian 12.
#
# Usage: tools/original/build.sh [ARCHIVE]
#   ARCHIVE  craft-box2d-*.tar.gz (default: ../shared/original-craft/craft-box2d-85c50b2.tar.gz
#            beside the repository root)
# Env:     CRAFT_ORIGINAL_HOME  cache root (default: $HOME/.cache/craft_dsl/original)
#          CRAFT_ORIGINAL_JOBS  parallel compile jobs (default: 2)
#
# Result:  <cache root>/<first 16 hex of the archive's sha256>/run/Testbed, with run/Data/ beside it
#          (run the binary with run/ as the working directory). Progress goes to stderr; the last
#          (only) line on stdout is the absolute path of the binary. A finished build is reused.
set -euo pipefail

die() {
    echo "build.sh: error: $*" >&2
    exit 1
}
note() { echo "build.sh: $*" >&2; }

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
archive="${1:-$here/../../../shared/original-craft/craft-box2d-85c50b2.tar.gz}"
[[ -f "$archive" ]] || die "archive not found: $archive (give its path as the first argument)"
archive="$(cd "$(dirname "$archive")" && pwd)/$(basename "$archive")"

# Debian packages: compiler, X11 headers for the bundled GLFW, FFmpeg/libpng/nlohmann-json for the
# simulator, and the headless runtime (Xvfb + Mesa's llvmpipe GL driver, loaded by GLFW via libGL).
packages=(
    g++ make
    libx11-dev libxrandr-dev libxinerama-dev libxcursor-dev libxi-dev
    libavcodec-dev libavutil-dev libswscale-dev libpng-dev nlohmann-json3-dev
    libgl1 libgl1-mesa-dri xvfb xauth
)

ensure_packages() {
    local missing=() pkg installed
    # one dpkg-query for all; it exits 1 when some package is unknown, which only means "missing"
    installed=" $({ dpkg-query -W -f='${Package}=${db:Status-Abbrev}\n' "${packages[@]}" 2>/dev/null || true; } |
        sed -n 's/=ii *$//p' | tr '\n' ' ') "
    for pkg in "${packages[@]}"; do
        [[ "$installed" == *" $pkg "* ]] || missing+=("$pkg")
    done
    command -v python3 >/dev/null 2>&1 || missing+=(python3-minimal)
    ((${#missing[@]} == 0)) && return 0
    [[ "$(id -u)" == 0 ]] || die "missing Debian packages (install them as root): ${missing[*]}"
    command -v apt-get >/dev/null 2>&1 || die "apt-get not found; needed to install: ${missing[*]}"
    note "installing ${missing[*]}"
    local log
    log="$(mktemp -t craft-original-apt.XXXXXX)"
    if ! apt-get update -qq >"$log" 2>&1 ||
        ! DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
            "${missing[@]}" >>"$log" 2>&1; then
        tail -n 30 "$log" >&2
        die "apt-get failed (full log: $log)"
    fi
    rm -f "$log"
}

command -v sha256sum >/dev/null 2>&1 || die "sha256sum not found (coreutils)"
# The cache key covers the archive and this folder's build recipe (edits, Makefile, VideoWriter.h), so a changed
# recipe builds anew.
key="$( { sha256sum "$archive" | cut -c1-64; cat "$here/patch_sources.py" "$here/Makefile" "$here/VideoWriter.h"; } |
    sha256sum | cut -c1-16)"
cache_root="${CRAFT_ORIGINAL_HOME:-$HOME/.cache/craft_dsl/original}"
dir="$cache_root/$key"
stamp="$dir/BUILD_COMPLETE"
binary="$dir/run/Testbed"

ensure_packages

if [[ -f "$stamp" && -x "$binary" ]]; then
    note "cached build: $dir"
    echo "$binary"
    exit 0
fi

mkdir -p "$cache_root"
exec 9>"$cache_root/$key.lock"
command -v flock >/dev/null 2>&1 && flock 9 # one builder per archive; others wait, then reuse it
if [[ -f "$stamp" && -x "$binary" ]]; then
    note "cached build (finished by another process): $dir"
    echo "$binary"
    exit 0
fi

start=$SECONDS
note "building from $archive into $dir"
rm -rf "$dir"
mkdir -p "$dir/src"
tar -xzf "$archive" -C "$dir/src" || die "could not unpack $archive"
shopt -s nullglob
roots=("$dir"/src/*/data_generation/2d/CRAFT-Box2D)
shopt -u nullglob
((${#roots[@]} == 1)) || die "no single */data_generation/2d/CRAFT-Box2D folder in $archive"
src="${roots[0]}"

python3 "$here/patch_sources.py" "$src" "$here/VideoWriter.h" >"$dir/patch.log" 2>&1 || {
    cat "$dir/patch.log" >&2
    die "source edits failed"
}

note "compiling (log: $dir/build.log)"
if ! make -f "$here/Makefile" -j"${CRAFT_ORIGINAL_JOBS:-2}" \
    SRC="$src" OBJ="$dir/obj" BIN="$dir/obj/bin/Testbed" >"$dir/build.log" 2>&1; then
    tail -n 40 "$dir/build.log" >&2
    die "compilation failed (full log: $dir/build.log)"
fi

# Ready-to-run folder: the simulator reads Data/Textures/eyes.png and Data/DroidSans.ttf from its cwd.
mkdir -p "$dir/run"
cp "$dir/obj/bin/Testbed" "$binary"
cp -R "$src/Testbed/Data" "$dir/run/Data"
[[ -f "$dir/run/Data/Textures/eyes.png" && -f "$dir/run/Data/DroidSans.ttf" ]] ||
    die "Data/ is incomplete in $dir/run"
for f in "$dir"/src/*/LICENSE; do [[ -f "$f" ]] && cp "$f" "$dir/LICENSE"; done
rm -rf "$dir/obj" # object files are not reused: a rebuild always starts from a fresh unpack

{
    echo "archive=$archive"
    echo "sha256=$(sha256sum "$archive" | cut -d' ' -f1)"
    echo "built=$(date -u +%Y-%m-%dT%H:%M:%SZ)"
    echo "seconds=$((SECONDS - start))"
    echo "binary=$binary"
} >"$stamp.tmp"
mv "$stamp.tmp" "$stamp"
note "done in $((SECONDS - start)) s"
echo "$binary"
