#!/usr/bin/env bash
# Build pybox2d with polygons of up to 128 vertices, as the original CRAFT simulator's Box2D is built, and install
# it in a Python, where it takes the place of the box2d wheel (the same module and physics: only the polygon cap
# differs, so the other engines run byte for byte as before). craft_dsl's engine `box2d128` needs it.
#
# Usage: tools/box2d128/build.sh
# Env:   PYTHON             the Python to install into (default: python, e.g. your venv's)
#        CRAFT_BOX2D_HOME   wheel cache (default: $HOME/.cache/craft_dsl/box2d128)
#
# From PyPI's box2d-py 2.3.8 source (Box2D 2.3 with its SWIG wrapper): b2_maxPolygonVertices 16 -> 128, and the
# distribution named box2d 2.3.10+craft128, so that craft-dsl's requirement box2d==2.3.10 stays met. Needs SWIG and
# a C++ compiler (Debian: swig g++, installed here when run as root). A wheel built before is reused.
set -euo pipefail

die() { echo "build.sh: error: $*" >&2; exit 1; }
note() { echo "build.sh: $*" >&2; }

python="${PYTHON:-python}"
command -v "$python" >/dev/null 2>&1 || die "no Python at '$python' (set PYTHON)"
home="${CRAFT_BOX2D_HOME:-$HOME/.cache/craft_dsl/box2d128}"
tag="$("$python" -c 'import sys; print(f"cp{sys.version_info[0]}{sys.version_info[1]}")')"
version="2.3.10+craft128"
wheels="$home/$tag"

ensure_tools() {
    local missing=()
    command -v swig >/dev/null 2>&1 || missing+=(swig)
    command -v g++ >/dev/null 2>&1 || missing+=(g++)
    ((${#missing[@]} == 0)) && return 0
    [[ "$(id -u)" == 0 ]] && command -v apt-get >/dev/null 2>&1 ||
        die "missing: ${missing[*]} (Debian: apt-get install ${missing[*]})"
    note "installing ${missing[*]}"
    apt-get update -qq >/dev/null 2>&1 || true
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null ||
        die "apt-get install ${missing[*]} failed"
}

wheel="$(ls "$wheels"/box2d-2.3.10+craft128-*.whl 2>/dev/null | head -n 1 || true)"
if [[ -z "$wheel" ]]; then
    ensure_tools
    work="$(mktemp -d -t craft-box2d128.XXXXXX)"
    trap 'rm -rf "$work"' EXIT
    note "fetching box2d-py 2.3.8's source"
    "$python" -m pip download --quiet --no-binary :all: --no-deps box2d-py==2.3.8 -d "$work" ||
        die "could not download box2d-py 2.3.8's source from PyPI"
    tar -xzf "$work"/box2d-py-2.3.8.tar.gz -C "$work"
    src="$work/box2d-py-2.3.8"
    "$python" "$(dirname "${BASH_SOURCE[0]}")/edit_source.py" "$src" "$version"
    note "building (a few minutes)"
    mkdir -p "$wheels"
    "$python" -m pip wheel --quiet --no-deps "$src" -w "$work/dist" >&2 ||
        die "the build failed"
    cp "$work"/dist/box2d-2.3.10+craft128-*.whl "$wheels"/
    wheel="$(ls "$wheels"/box2d-2.3.10+craft128-*.whl | head -n 1)"
fi
note "installing $wheel"
"$python" -m pip install --quiet --force-reinstall --no-deps "$wheel"
"$python" -c 'import Box2D, math; Box2D.b2PolygonShape(vertices=[(math.cos(k / 20.4), math.sin(k / 20.4)) for k in range(128)])' ||
    die "the installed Box2D still takes fewer than 128 vertices"
note "done: Box2D takes polygons of 128 vertices; craft-dsl's engine box2d128 runs"
echo "$wheel"
