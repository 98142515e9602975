#!/usr/bin/env bash
# Does lavapipe's JIT lose speed on this host because of how LLVM tunes for the CPU?
#
# Mesa's gallivm asks LLVM for the host's CPU name (llvm::sys::getHostCPUName) and tunes the
# JIT for it. LLVM 15 predates Intel's Sapphire/Emerald Rapids and names them
# "icelake-client" (a laptop part); Mesa also picks its vector width (LP_NATIVE_VECTOR_WIDTH,
# 256 bits on AVX2/AVX-512 hosts). This script measures, in pairs (scripts/paired-timing.sh:
# both sides at once, one lavapipe thread each, CPU seconds), the default against:
#   * LLVM told another CPU name: a small shim, preloaded, answers getHostCPUName with
#     $LLVM_HOST_CPU (gallivm calls it through the dynamic linker, so the shim takes its place;
#     an unknown name makes LLVM print "not a recognized processor", the proof it is used);
#   * another vector width (LP_NATIVE_VECTOR_WIDTH=128 or 512).
# A ratio A/B above 1 means the variant (B) is faster.
#
#   bash scripts/lavapipe-cpu-tuning.sh [ROUNDS] [SCENE]     # default 12, scenes/cornell-box.toml
#
# Environment: VARIANTS (default "LLVM_HOST_CPU=sapphirerapids LLVM_HOST_CPU=icelake-server
# LP_NATIVE_VECTOR_WIDTH=512 LP_NATIVE_VECTOR_WIDTH=128"); COMMON as paired-timing.sh takes it.
# Needs a C compiler (gcc) for the shim.
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-12}
scene=${2:-scenes/cornell-box.toml}
variants=${VARIANTS:-LLVM_HOST_CPU=sapphirerapids LLVM_HOST_CPU=icelake-server LP_NATIVE_VECTOR_WIDTH=512 LP_NATIVE_VECTOR_WIDTH=128}
[ -x target/release/brdfwave ] || cargo build --release --quiet
shim=$(mktemp -d)
trap 'rm -rf "$shim"' EXIT
cat > "$shim/cpuname.c" <<'EOF'
#include <stdlib.h>
#include <string.h>
/* llvm::StringRef llvm::sys::getHostCPUName(void), answered from $LLVM_HOST_CPU. The StringRef
   (pointer, length) is returned in registers, as this struct is. */
struct string_ref { const char *data; size_t length; };
struct string_ref _ZN4llvm3sys14getHostCPUNameEv(void) {
    const char *name = getenv("LLVM_HOST_CPU");
    struct string_ref r = { name ? name : "generic", name ? strlen(name) : 7 };
    return r;
}
EOF
gcc -O2 -shared -fPIC -o "$shim/libcpuname.so" "$shim/cpuname.c"

cpu_field() { grep -m1 "^$1" /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'; }
echo "host: $(cpu_field 'model name') (family $(cpu_field 'cpu family') model $(cpu_field 'model') stepping $(cpu_field 'stepping')), $(nproc) threads"
llvm_default=$(python3 - <<'EOF' 2>/dev/null || echo unknown
import ctypes, ctypes.util
lib = ctypes.CDLL("libLLVM-15.so.1")
lib.LLVMGetHostCPUName.restype = ctypes.c_char_p
print(lib.LLVMGetHostCPUName().decode())
EOF
)
echo "LLVM 15's name for this CPU: $llvm_default"
# The shim must be in effect: an unknown name is reported by LLVM.
check=$(LD_PRELOAD=$shim/libcpuname.so LLVM_HOST_CPU=no-such-cpu target/release/brdfwave render \
    "$scene" --backend gpu --res 8x8 --spp 1 --quiet --out "$shim/check.exr" 2>&1 || true)
if ! grep -q "not a recognized processor" <<< "$check"; then
    echo "the shim does not reach lavapipe's JIT here (another LLVM?): CPU names not measured" >&2
    variants=$(tr ' ' '\n' <<< "$variants" | grep -v '^LLVM_HOST_CPU=' | tr '\n' ' ')
fi
for v in $variants; do
    case $v in
        LLVM_HOST_CPU=*) b="--backend gpu ENV=LD_PRELOAD=$shim/libcpuname.so ENV=$v" ;;
        *) b="--backend gpu ENV=$v" ;;
    esac
    echo
    echo "== default (A) against $v (B), $scene"
    SKIP=1 bash scripts/paired-timing.sh $((rounds + 1)) "$scene" "--backend gpu" "$b"
done
