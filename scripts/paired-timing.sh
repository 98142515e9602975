#!/usr/bin/env bash
# A/B cost of two render configurations, measured in pairs: A and B render at the same time,
# one thread each (on a 2-core machine, one core each), their positions swapped every round,
# and each round gives the ratio of their CPU seconds (user + system). Both see the same spell
# of a busy host, so the ratio is steadier than sequential timings: on the 2-core VM of
# docs/bench-log.md sequential runs swing by ±10 %, while 12–16 pairs resolve 2 %.
#
#   bash scripts/paired-timing.sh ROUNDS SCENE "A ARGS" "B ARGS"
#
# A ARGS and B ARGS are the words that differ, each as one string, given to
# `brdfwave render SCENE --threads 1 --quiet` after the common options (COMMON, default
# "--res 256x256 --spp 16 --max-depth 8 --set integrator.russian_roulette=false"). A word
# BIN=PATH in either selects another brdfwave executable for that side (to compare builds);
# ENV=NAME=VALUE sets an environment variable for that side. Prints each round's ratio A/B
# and the mean with its standard error. For lavapipe the first round also compiles the
# pipelines: use ROUNDS + 1 and read the summary without it (SKIP=1 drops it).
#
#   bash scripts/paired-timing.sh 12 scenes/cornell-box.toml \
#       "--backend cpu --sampler multijitter" "--backend cpu --sampler independent"
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -ne 4 ]; then
    sed -n '2,19p' "$0" >&2
    exit 2
fi
rounds=$1 scene=$2 a=$3 b=$4
read -r -a common <<< "${COMMON:---res 256x256 --spp 16 --max-depth 8 --set integrator.russian_roulette=false}"
default_bin=$PWD/target/release/brdfwave
[ -x "$default_bin" ] || cargo build --release --quiet
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# bin_of SIDE_ARGS: the executable a side runs (its BIN= word, else the default).
bin_of() {
    local bin=$default_bin
    for word in $1; do
        case $word in BIN=*) bin=${word#BIN=} ;; esac
    done
    echo "$bin"
}

# one SIDE_ARGS TIMEFILE: one render, its CPU seconds written to TIMEFILE.
one() {
    local bin env=() args=()
    bin=$(bin_of "$1")
    for word in $1; do
        case $word in
            BIN=*) ;;
            ENV=*) env+=("${word#ENV=}") ;;
            *) args+=("$word") ;;
        esac
    done
    env "${env[@]}" /usr/bin/time -f "%U %S" -o "$2" "$bin" render "$scene" --threads 1 --quiet \
        "${common[@]}" "${args[@]}" --out "$2.exr"
}

# Which program each side runs: `--version` names the commit, and `.modified-<hash>` where it
# was built from uncommitted changes (a binary an experiment left behind names main's commit).
echo "A: $("$(bin_of "$a")" --version) ($(bin_of "$a"))"
echo "B: $("$(bin_of "$b")" --version) ($(bin_of "$b"))"

ratios=()
for r in $(seq "$rounds"); do
    if [ $((r % 2)) = 0 ]; then
        one "$a" "$tmp/a" & one "$b" "$tmp/b" & wait
    else
        one "$b" "$tmp/b" & one "$a" "$tmp/a" & wait
    fi
    ta=$(awk '{print $1 + $2}' "$tmp/a")
    tb=$(awk '{print $1 + $2}' "$tmp/b")
    ratio=$(python3 -c "print(f'{$ta / $tb:.4f}')")
    echo "round $r: A $ta s, B $tb s, A/B $ratio"
    ratios+=("$ratio")
done
python3 - "${SKIP:-0}" "${ratios[@]}" <<'EOF'
import statistics, sys
skip, r = int(sys.argv[1]), [float(x) for x in sys.argv[2:]]
r = r[skip:]
sem = statistics.stdev(r) / len(r) ** 0.5 if len(r) > 1 else float("nan")
print(f"A/B over {len(r)} rounds: mean {statistics.mean(r):.3f} ± {sem:.3f} (standard error), median {statistics.median(r):.3f}")
EOF
