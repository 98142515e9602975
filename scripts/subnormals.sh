#!/usr/bin/env bash
# Do subnormal numbers cost this render anything, and where do they come from?
#
# Intel cores compute SSE/AVX operations on subnormal operands or results in microcode assists,
# about a hundred times an ordinary operation, unless the thread's MXCSR has flush-to-zero (FTZ)
# and denormals-are-zero (DAZ) set. Neither lavapipe's threads nor ours set them (and the
# images must not depend on it), so the code must not make subnormals where it runs often:
# docs/bench-log.md, "Subnormal ray origins", found ray origins on coordinate planes moved to
# 1.4e-45, which made lavapipe 2x and the CPU reference 1.2x slower on the Cornell box.
#
#   bash scripts/subnormals.sh time [ROUNDS] [SCENE]   # default 4, scenes/cornell-box.toml
#       Paired (scripts/paired-timing.sh), both backends: plain (A) against FTZ and DAZ set in
#       every thread by a preloaded shim (B). A/B near 1: subnormals cost nothing here.
#   bash scripts/subnormals.sh trap [SCENE]
#       The CPU reference (64x64, 4 spp, one thread) under gdb with the denormal-operand and
#       underflow exceptions unmasked: the backtrace of the first subnormal it meets, or
#       "exited normally" when it meets none. Libm's own underflows (expf of a large negative
#       argument) stop it too; set-up code may stop it once.
#
# Needs a C compiler (gcc) for the shims, and gdb for `trap`. COMMON as paired-timing.sh takes it.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-}
case $mode in
    time) rounds=${2:-4} scene=${3:-scenes/cornell-box.toml} ;;
    trap) scene=${2:-scenes/cornell-box.toml} ;;
    *) sed -n '2,20p' "$0" >&2; exit 2 ;;
esac
[ -x target/release/brdfwave ] || cargo build --release --quiet
shim=$(mktemp -d)
trap 'rm -rf "$shim"' EXIT
# One shim source, two builds: MXCSR_SET bits are set and MXCSR_CLEAR bits cleared in the main
# thread (a constructor) and in every thread pthread_create starts.
cat > "$shim/mxcsr.c" <<'EOF'
#define _GNU_SOURCE
#include <dlfcn.h>
#include <pthread.h>
#include <stdlib.h>
#include <xmmintrin.h>
static void apply(void) { _mm_setcsr((_mm_getcsr() | MXCSR_SET) & ~MXCSR_CLEAR); }
struct start { void *(*fn)(void *); void *arg; };
static void *trampoline(void *p) {
    struct start s = *(struct start *)p;
    free(p);
    apply();
    return s.fn(s.arg);
}
int pthread_create(pthread_t *t, const pthread_attr_t *a, void *(*fn)(void *), void *arg) {
    static int (*real)(pthread_t *, const pthread_attr_t *, void *(*)(void *), void *);
    if (!real) real = dlsym(RTLD_NEXT, "pthread_create");
    struct start *s = malloc(sizeof *s);
    if (!s) return real(t, a, fn, arg);
    s->fn = fn;
    s->arg = arg;
    return real(t, a, trampoline, s);
}
__attribute__((constructor)) static void init(void) { apply(); }
EOF
# FTZ is bit 15, DAZ bit 6; the masks of the denormal-operand and underflow exceptions are
# bits 8 and 11.
gcc -O2 -shared -fPIC -DMXCSR_SET=0x8040u -DMXCSR_CLEAR=0u -o "$shim/ftz.so" "$shim/mxcsr.c" -ldl
gcc -O2 -shared -fPIC -DMXCSR_SET=0u -DMXCSR_CLEAR=0x0900u -o "$shim/trap.so" "$shim/mxcsr.c" -ldl
if [ "$mode" = time ]; then
    echo "CPU reference, plain / FTZ+DAZ:"
    bash scripts/paired-timing.sh "$rounds" "$scene" "--backend cpu" \
        "--backend cpu ENV=LD_PRELOAD=$shim/ftz.so" | tail -1
    echo "lavapipe, plain / FTZ+DAZ (the first round, which compiles, left out):"
    SKIP=1 bash scripts/paired-timing.sh "$((rounds + 1))" "$scene" "--backend gpu" \
        "--backend gpu ENV=LD_PRELOAD=$shim/ftz.so" | tail -1
else
    # gdb's status is 1 when the render ends normally (then `bt` has no stack): not a failure.
    { gdb -q -batch -ex "set environment LD_PRELOAD=$shim/trap.so" -ex run -ex "bt 8" \
        --args target/release/brdfwave render "$scene" --backend cpu --res 64x64 --spp 4 \
        --threads 1 --quiet --out "$shim/trap.exr" 2>&1 || true; } |
        grep -v -E '^\[(New |Thread |Switching )' | grep -A10 -E 'SIGFPE|exited'
fi
