#!/usr/bin/env bash
# Writes the measured material of scenes/material-preview.toml: a synthetic MERL table (35 MB,
# too large to commit) sampled by `brdfwave brdf merl` from the analytic material in
# scenes/material-preview/measured.material, as scenes/material-preview/measured.binary. A table
# that is there already is kept. The scene's images are committed; they are made by
# scripts/material-preview-images.py.
#
# usage: bash scripts/material-preview.sh
# The program is $BRDFWAVE, else `brdfwave` on PATH, else this checkout's target/release/brdfwave.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bin=${BRDFWAVE:-$(command -v brdfwave || echo "$here/target/release/brdfwave")}
dir="$here/scenes/material-preview"
table="$dir/measured.binary"
if [ -s "$table" ]; then
    echo "material-preview: $table is there already" >&2
    exit 0
fi
exec "$bin" brdf merl --material "$(cat "$dir/measured.material")" --out "$table"
