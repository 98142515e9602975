#!/usr/bin/env bash
# Mesa 25's lavapipe from Debian 12's bookworm-backports, unpacked into a directory beside the
# system's Mesa 22.3.6 and not installed: for `brdfwave rays` (ray queries need lavapipe from
# Mesa 24.1) and for comparing lavapipe versions (docs/bench-log.md). It prints, on stdout, the
# two environment variables that make the Vulkan loader use it, so that
#
#   eval "$(bash scripts/mesa-backports.sh)"
#   brdfwave rays scenes/cornell-box.toml
#
# runs on it. The directory (default out/mesa-backports) is made once and reused. Needs apt-get
# and network access to deb.debian.org; nothing outside the directory changes.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=$(realpath -m "${1:-out/mesa-backports}")
lib=$dir/root/usr/lib/x86_64-linux-gnu
if [ ! -f "$lib/libvulkan_lvp.so" ]; then
    mkdir -p "$dir/lists/partial" "$dir/cache/archives/partial" "$dir/debs" "$dir/root"
    echo "deb http://deb.debian.org/debian bookworm-backports main" > "$dir/sources.list"
    apt=(apt-get -q -o "Dir::Etc::SourceList=$dir/sources.list" -o Dir::Etc::SourceParts=/dev/null
         -o "Dir::State::Lists=$dir/lists" -o "Dir::Cache=$dir/cache")
    "${apt[@]}" update >&2
    # lavapipe and the libdrm it was built against; LLVM 15 is Debian 12's own.
    (cd "$dir/debs" && "${apt[@]}" download mesa-vulkan-drivers/bookworm-backports \
        libdrm2/bookworm-backports >&2)
    for deb in "$dir"/debs/*.deb; do
        dpkg-deb -x "$deb" "$dir/root"
    done
fi
icd=$dir/lvp_icd.json
sed "s#\"library_path\": \"[^\"]*\"#\"library_path\": \"$lib/libvulkan_lvp.so\"#" \
    "$dir/root/usr/share/vulkan/icd.d/lvp_icd.json" > "$icd"
echo "export VK_ICD_FILENAMES=$icd"
echo "export LD_LIBRARY_PATH=$lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
