#!/usr/bin/env bash
# relMSE at equal samples per pixel, as a mean over seeds: ours (the CPU reference, which draws
# the GPU's numbers bit for bit) with each of our samplers beside Mitsuba 3's llvm_ad_rgb with
# each of its stratified samplers, on the Cornell box and the glossy Cornell box. One render
# of a low sample count is a noisy estimate of its error (the bench's table has one render per
# configuration; at 16 spp on the glossy box two seeds can differ by 20 %), so this renders
# SEEDS of them and prints the mean and its standard error.
#
#   bash scripts/sampler-seeds.sh [OUTDIR]      # default out/sampler-seeds
#
# 128x128, max depth 8, no Russian roulette; each scene's reference is 8192 spp of the CPU
# reference with a seed no test render uses (cached in OUTDIR). About 15 minutes on 2 cores
# with SEEDS=8 (the default), most of it the two references. Mitsuba is skipped when its
# Python module does not load (DRJIT_LIBLLVM_PATH may need to point at libLLVM).
# Environment: SEEDS, SPPS (default "16 64 256"), SAMPLERS (ours, default
# "multijitter sobol independent"), MI_SAMPLERS (default "multijitter ldsampler stratified").
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
bin=$PWD/target/release/brdfwave
out=${1:-out/sampler-seeds}
seeds=${SEEDS:-8}
spps=${SPPS:-16 64 256}
ours=${SAMPLERS:-multijitter sobol independent}
theirs=${MI_SAMPLERS:-multijitter ldsampler stratified}
common=(--res 128x128 --max-depth 8 --set integrator.russian_roulette=false --quiet)
mkdir -p "$out"

relmse() { "$bin" diff "$1" "$2" --json | python3 -c 'import json, sys; print(json.load(sys.stdin)["relmse"])'; }
summary() { # name spp values...
    python3 - "$@" <<'EOF'
import statistics, sys
name, spp, v = sys.argv[1], sys.argv[2], [float(x) for x in sys.argv[3:]]
sem = statistics.stdev(v) / len(v) ** 0.5 if len(v) > 1 else float("nan")
print(f"| {name} | {spp} | {statistics.mean(v):.4e} | {sem:.1e} | {len(v)} |")
EOF
}

for scene in cornell-box cornell-box-glossy; do
    dir=$out/$scene
    mkdir -p "$dir"
    ref=$dir/reference.exr
    [ -f "$ref" ] || "$bin" render "scenes/$scene.toml" --backend cpu "${common[@]}" --spp 8192 --seed 777777 --out "$ref"
    echo "### $scene"
    echo
    echo "| configuration | spp | relMSE, mean | standard error | seeds |"
    echo "|---|---|---|---|---|"
    for sampler in $ours; do
        for spp in $spps; do
            values=()
            for seed in $(seq 1 "$seeds"); do
                img=$dir/ours-$sampler-$spp-$seed.exr
                "$bin" render "scenes/$scene.toml" --backend cpu "${common[@]}" --spp "$spp" --seed "$seed" --sampler "$sampler" --out "$img"
                values+=("$(relmse "$img" "$ref")")
            done
            summary "brdfwave $sampler" "$spp" "${values[@]}"
        done
    done
    xml=$dir/scene.xml
    log=$("$bin" convert --to mitsuba "scenes/$scene.toml" "$xml" 2>&1) || { echo "$log" >&2; exit 1; }
    sed -i 's/name="width" value="[0-9]*"/name="width" value="128"/; s/name="height" value="[0-9]*"/name="height" value="128"/' "$xml"
    if python3 - "$xml" "$dir" "$seeds" "$spps" $theirs <<'EOF'
import os, sys
sys.path.insert(0, "scripts")
try:
    import mitsuba as mi
    import numpy as np
    mi.set_variant("llvm_ad_rgb")
except Exception as e:
    print(f"(Mitsuba skipped: {e})", file=sys.stderr)
    sys.exit(1)
from mitsuba_peer import load_scene
mi.set_log_level(mi.LogLevel.Error)
xml, out, seeds, spps = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split()
for sampler in sys.argv[5:]:
    scene = load_scene(mi, xml, sampler)
    for spp in spps:
        for seed in range(1, seeds + 1):
            img = np.array(mi.render(scene, spp=int(spp), seed=1000 + seed), dtype=np.float32)
            mi.Bitmap(img).write(os.path.join(out, f"mitsuba-{sampler}-{spp}-{seed}.exr"))
EOF
    then
        for sampler in $theirs; do
            for spp in $spps; do
                values=()
                for seed in $(seq 1 "$seeds"); do
                    values+=("$(relmse "$dir/mitsuba-$sampler-$spp-$seed.exr" "$ref")")
                done
                summary "Mitsuba llvm_ad_rgb $sampler" "$spp" "${values[@]}"
            done
        done
    fi
    echo
done
