#!/usr/bin/env bash
# brdfwave's CPU traversal beside Mitsuba 3's (Embree, `llvm_ad_rgb`), on the same kinds of
# rays (docs/cli/rays.md; docs/bench-log.md, "The CPU traversal beside Embree's"). Both on
# all the host's threads, warm, the fastest of 5 runs.
#
#   bash scripts/embree-rays.sh [SCENE.toml] [RES]   # default scenes/cornell-box.toml, 256
#
# Prints `brdfwave rays --ours-only` (its last column is the CPU traversal) and
# scripts/embree-rays.py's table for the scene as `brdfwave convert` writes it. Needs Mitsuba
# 3 (`pip install mitsuba`) and, for Dr.Jit's LLVM backend, a libLLVM of version 16 or later:
# DRJIT_LIBLLVM_PATH, else the Rust toolchain's own (Debian 12's LLVM 15 crashes Dr.Jit).
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:-scenes/cornell-box.toml} res=${2:-256}
if ! python3 -c 'import mitsuba' 2> /dev/null; then
    echo "embree-rays.sh: needs Mitsuba 3 for python3 (pip install mitsuba)" >&2
    exit 1
fi
[ -x target/release/brdfwave ] || cargo build --release --quiet
if [ -z "${DRJIT_LIBLLVM_PATH:-}" ]; then
    for f in "$(rustc --print sysroot)"/lib/libLLVM*.so*; do
        # The shared object itself; beside it, libLLVM-NN-rust-*.so is a linker script.
        if [ "$(head -c 4 "$f" | od -An -c | tr -d ' ')" = '177ELF' ]; then
            export DRJIT_LIBLLVM_PATH=$f
            break
        fi
    done
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "Host: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) threads."
target/release/brdfwave rays "$scene" --res "${res}x$res" --ours-only
echo
target/release/brdfwave convert --to mitsuba "$scene" "$tmp/scene.xml" > /dev/null 2>&1
python3 scripts/embree-rays.py "$tmp/scene.xml" "$res"
