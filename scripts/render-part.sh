#!/usr/bin/env bash
# Renders part INDEX of PARTS of a scene: the sample indices [INDEX·SPP/PARTS, (INDEX+1)·SPP/PARTS),
# so that parts 0..PARTS-1 together hold samples 0..SPP once, into DIR/part-INDEX-of-PARTS.bwfilm.
# The name is fixed and the file is written atomically, so a part that failed or was killed is
# simply rendered again, and one that exists is complete and is kept. The batch-scheduler examples
# (docs/distributed/) and scripts/render-parts.sh run this once per part; then
#   brdfwave merge DIR/part-*-of-PARTS.bwfilm --samples 0..SPP --out image.exr
#
# usage: scripts/render-part.sh INDEX PARTS SCENE SPP DIR [render options, e.g. --res 1024x1024]
# The program is $BRDFWAVE, else `brdfwave` on PATH, else this checkout's target/release/brdfwave.
set -euo pipefail
bin=${BRDFWAVE:-$(command -v brdfwave || echo "$(dirname "$0")/../target/release/brdfwave")}
[ $# -ge 5 ] || { sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }  # the usage above
index=$1 parts=$2 scene=$3 spp=$4 dir=$5
shift 5
for n in "$index" "$parts" "$spp"; do
    case $n in '' | *[!0-9]*) echo "render-part: INDEX, PARTS and SPP must be whole numbers, got '$n'" >&2; exit 2 ;; esac
done
if [ "$parts" -lt 1 ] || [ "$index" -ge "$parts" ] || [ "$parts" -gt "$spp" ]; then
    echo "render-part: need 0 <= INDEX < PARTS <= SPP, got INDEX $index, PARTS $parts, SPP $spp" >&2
    exit 2
fi
part="$dir/part-$index-of-$parts.bwfilm"
if [ -s "$part" ]; then
    echo "render-part: $part is there already" >&2
    exit 0
fi
mkdir -p "$dir"
start=$((index * spp / parts)) end=$(((index + 1) * spp / parts))
exec "$bin" render "$scene" --spp "$spp" --samples "$start..$end" --out "$part" "$@"
