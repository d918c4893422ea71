#!/usr/bin/env bash
# Installs Google's SwiftShader, a second software Vulkan driver, when it is missing, and
# prints the path of its ICD file (vk_swiftshader_icd.json) on stdout; messages go to stderr.
#
#   icd=$(bash scripts/install-swiftshader.sh) && VK_ICD_FILENAMES=$icd cargo test --release ...
#
# Debian 12 has no SwiftShader package of its own: chromium's data package `chromium-common`
# ships libvk_swiftshader.so and its ICD file in chromium's library directory. Without its
# recommends it is two packages (chromium-common, xdg-utils; about 32 MB to download), and
# nothing of chromium runs. SwiftShader's limits are stricter than lavapipe's (10 storage
# buffers per shader stage, 256 invocations per workgroup), so the kernels passing on both
# have passed two independent Vulkan implementations.
#
# Idempotent: does nothing but print the path when the ICD file is already installed.
# Exits 1 (having printed nothing on stdout) where it cannot be installed.
set -euo pipefail

log() { echo "install-swiftshader: $*" >&2; }

find_icd() {
    local f
    # The package's own file list first, then chromium's usual library directory.
    f=$(dpkg -L chromium-common 2>/dev/null | grep -m1 '/vk_swiftshader_icd\.json$' || true)
    if [ -z "$f" ]; then
        f=$(find /usr/lib/chromium /usr/lib64/chromium -name vk_swiftshader_icd.json 2>/dev/null | head -n 1 || true)
    fi
    [ -n "$f" ] && [ -f "$f" ] || return 1
    echo "$f"
}

if icd=$(find_icd); then
    echo "$icd"
    exit 0
fi

if ! command -v apt-get >/dev/null 2>&1; then
    log "no apt-get here: install SwiftShader (libvk_swiftshader.so + vk_swiftshader_icd.json) by hand."
    exit 1
fi

SUDO=""
if [ "$(id -u)" != 0 ]; then
    if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
        log "not root and no sudo: ask an administrator to run"
        log "  apt-get install --no-install-recommends chromium-common"
        exit 1
    fi
fi

export DEBIAN_FRONTEND=noninteractive
log "installing SwiftShader (chromium-common, without recommends)"
$SUDO apt-get update -qq || log "apt-get update reported errors (continuing)"
if ! $SUDO apt-get install -y -qq --no-install-recommends chromium-common >/dev/null; then
    log "apt-get install chromium-common failed"
    exit 1
fi
if ! icd=$(find_icd); then
    log "chromium-common is installed but ships no vk_swiftshader_icd.json"
    exit 1
fi
log "chromium-common $(dpkg-query -W -f='${Version}' chromium-common): $icd"
echo "$icd"
