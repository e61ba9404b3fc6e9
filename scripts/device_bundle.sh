#!/bin/sh
# What a lent GPU machine lacks to run noisybolt, gathered here for scripts/gpu_breakout.sh:
#   .whl/   wheels (CPython 3.12, manylinux x86-64) of the packages its image lacks, at the
#           versions this checkout's .venv holds (its image has torch, numpy, opencv, ...)
#   .mona/  the MONA binary and its libraries (ltlf2dfa calls it; no apt there)
# Both are git-ignored (.git/info/exclude) and travel with `carry`. Run from the repo root,
# after `make setup`:
#   sh scripts/device_bundle.sh
set -eu
venv=${VENV:-.venv}
packages="gymnasium ale-py stable-baselines3 farama-notifications minigrid pygame-ce ltlf2dfa
lark dd"
# sdists only on the index: built here as pure-Python wheels
pure="astutils ply"
version() {
    "$venv/bin/python" -m pip show "$1" 2>/dev/null | awk '/^Version:/ {print $2}'
}
mkdir -p .git/info .whl .mona
for path in /.whl/ /.mona/ /.nbcache/; do
    grep -qx "$path" .git/info/exclude 2>/dev/null || echo "$path" >>.git/info/exclude
done
for name in $packages; do
    v=$(version "$name")
    if [ -z "$v" ]; then
        echo "device_bundle: $name is not in $venv (run make setup first)" >&2
        exit 1
    fi
    python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 \
        --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
        --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 --platform any \
        -d .whl "$name==$v"
done
for name in $pure; do
    "$venv/bin/python" -m pip wheel -q --no-deps -w .whl "$name==$(version "$name")"
done
mona=$(command -v mona) || { echo "device_bundle: no mona here (make setup installs it)" >&2; exit 1; }
cp "$mona" .mona/
ldd "$mona" | awk '/libmona/ {print $3}' | xargs -r -I{} cp {} .mona/
ls .whl .mona
du -sh .whl .mona
