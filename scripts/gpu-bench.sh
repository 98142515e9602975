#!/usr/bin/env bash
# The bench on an NVIDIA GPU beside Mitsuba 3's cuda_ad_rgb, in under 10 minutes set-up
# included: the diffuse, glossy and 1M-triangle Cornell scenes at 256x256, max depth 8, our
# wavefront and megakernel schedules against Mitsuba's CUDA variant with each of its samplers,
# equal-time efficiency in each out/gpu-bench-*/bench.md. Prints the card's name and driver
# first: record them beside every figure.
#
#   bash scripts/gpu-bench.sh                  # the first Vulkan device whose name has "nvidia"
#   GPU_DEVICE="H100" bash scripts/gpu-bench.sh
#   MITSUBA_WHEELS=DIR bash scripts/gpu-bench.sh   # install Mitsuba from wheels in DIR (no network)
#
# Needs the NVIDIA driver with its Vulkan ICD, Rust (or a built target/release/brdfwave), python3
# and Mitsuba 3 (pip install mitsuba numpy, or the wheels of mitsuba, drjit and numpy in
# MITSUBA_WHEELS). The references are rendered on the GPU by our wavefront path (2048 spp, a
# minute or two); the bench's relMSE is against them for every configuration alike.
set -euo pipefail
cd "$(dirname "$0")/.."
dev=${GPU_DEVICE:-nvidia}
command -v nvidia-smi > /dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
[ -x target/release/brdfwave ] || cargo build --release --quiet
bin=./target/release/brdfwave
$bin devices
if ! python3 -c "import mitsuba" 2> /dev/null; then
    if [ -n "${MITSUBA_WHEELS:-}" ]; then
        pip install --no-index --find-links "$MITSUBA_WHEELS" mitsuba numpy
    else
        pip install mitsuba numpy
    fi
fi
python3 -c "import mitsuba as mi; mi.set_variant('cuda_ad_rgb'); print('mitsuba', mi.__version__, 'cuda_ad_rgb')"
mkdir -p out/gpu-bench-refs
common=(--res 256x256 --max-depth 8 --device "$dev")
for s in cornell-box cornell-box-glossy; do
    [ -f out/gpu-bench-refs/$s.exr ] || $bin render scenes/$s.toml --res 256x256 --max-depth 8 \
        --spp 2048 --device "$dev" --quiet --out out/gpu-bench-refs/$s.exr
done
peers=mitsuba-cuda,mitsuba-cuda-multijitter,mitsuba-cuda-stratified,mitsuba-cuda-ldsampler
ours=wavefront,wavefront-sobol,megakernel
$bin bench scenes/cornell-box.toml "${common[@]}" --reference out/gpu-bench-refs/cornell-box.exr \
    --configs "$ours,$peers" --min-spp 256 --budget "${GPU_BENCH_BUDGET:-90}" --out out/gpu-bench-diffuse
$bin bench scenes/cornell-box-glossy.toml "${common[@]}" --reference out/gpu-bench-refs/cornell-box-glossy.exr \
    --configs "$ours,$peers" --min-spp 256 --budget "${GPU_BENCH_BUDGET:-90}" --out out/gpu-bench-glossy
python3 scripts/bumpy-scene.py out/bumpy 1048576 > /dev/null
$bin bench out/bumpy/cornell-box-bumpy.toml "${common[@]}" --reference-spp 256 \
    --configs "wavefront,megakernel,mitsuba-cuda-multijitter" --budget "${GPU_BENCH_BUDGET:-90}" --out out/gpu-bench-bumpy
for d in diffuse glossy bumpy; do
    echo "== $d"
    head -40 out/gpu-bench-$d/bench.md
done
