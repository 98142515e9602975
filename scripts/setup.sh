#!/usr/bin/env bash
# Installs what brdfwave needs on Debian 12 beyond Rust itself: lavapipe (Mesa's CPU Vulkan
# driver), the Vulkan loader, the validation layers, and the static shaderc/glslang libraries
# that build.rs links (so shaderc is not built from source). Idempotent; quiet when all is there.
set -euo pipefail
pkgs=(mesa-vulkan-drivers libvulkan1 vulkan-validationlayers libshaderc-dev glslang-dev spirv-tools)
missing=()
for p in "${pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    echo "setup: installing ${missing[*]}" >&2
    $sudo apt-get update -q
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
command -v cargo >/dev/null || { echo "setup: cargo not found; install Rust (https://rustup.rs)" >&2; exit 1; }
