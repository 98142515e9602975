#!/usr/bin/env bash
# Renders a scene split into PARTS sample ranges, in up to JOBS local processes at a time
# (xargs -P), then merges them into OUT. The parts go to OUT's name with `.parts` in place of
# its extension (scripts/render-part.sh); run again after a failure or a kill, it renders only
# the parts that are missing.
#
# usage: scripts/render-parts.sh SCENE SPP PARTS JOBS OUT [render options, e.g. --res 1024x1024]
# The program is $BRDFWAVE, else `brdfwave` on PATH, else this checkout's target/release/brdfwave.
set -euo pipefail
bin=${BRDFWAVE:-$(command -v brdfwave || echo "$(dirname "$0")/../target/release/brdfwave")}
[ $# -ge 5 ] || { sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }  # the usage above
scene=$1 spp=$2 parts=$3 jobs=$4 out=$5
shift 5
case $jobs in '' | *[!0-9]* | 0) echo "render-parts: JOBS must be a positive whole number, got '$jobs'" >&2; exit 2 ;; esac
here=$(dirname "$0")
dir="${out%.*}.parts"
seq 0 $((parts - 1)) |
    BRDFWAVE=$bin xargs -P "$jobs" -I{} bash "$here/render-part.sh" {} "$parts" "$scene" "$spp" "$dir" "$@" >/dev/null
files=()
for i in $(seq 0 $((parts - 1))); do files+=("$dir/part-$i-of-$parts.bwfilm"); done
exec "$bin" merge "${files[@]}" --samples "0..$spp" --out "$out"
