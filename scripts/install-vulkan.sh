#!/usr/bin/env bash
# Installs the Vulkan loader and Mesa's lavapipe (the software Vulkan driver) when they are
# missing, so that wgpu finds an adapter on a machine without a GPU.
#
# Debian 12 ships Mesa 22.3, whose lavapipe silently caps a shader invocation at 65,535 loop
# iterations (see docs/platform.md); on Debian 12 this script therefore installs
# Mesa 25 from bookworm-backports. The backports entry is derived from the machine's own
# Debian source list, so whatever mirror the machine already uses is reused.
#
# Idempotent: does nothing when a lavapipe of Mesa >= 23 is already installed.
# Set FLUXSWARM_SKIP_VULKAN_INSTALL=1 to skip entirely (e.g. on a machine with a real GPU).
set -euo pipefail

[ "${FLUXSWARM_SKIP_VULKAN_INSTALL:-0}" = 1 ] && exit 0

log() { echo "install-vulkan: $*" >&2; }

mesa_major() {
    dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | sed -E 's/^([0-9]+:)?([0-9]+).*/\2/'
}

have_good_lavapipe() {
    dpkg-query -W -f='${Status}' libvulkan1 2>/dev/null | grep -q "install ok installed" || return 1
    local major
    major=$(mesa_major)
    [ -n "$major" ] && [ "$major" -ge 23 ]
}

if have_good_lavapipe; then
    exit 0
fi

if ! command -v apt-get >/dev/null 2>&1; then
    log "no apt-get here: install a Vulkan loader and Mesa's lavapipe (Mesa >= 23) by hand,"
    log "or run on a machine with a GPU driver. Continuing without installing."
    exit 0
fi

SUDO=""
if [ "$(id -u)" != 0 ]; then
    if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
        log "not root and no sudo: cannot install the software Vulkan driver."
        log "Ask an administrator to run: apt-get install libvulkan1 mesa-vulkan-drivers"
        exit 1
    fi
fi

export DEBIAN_FRONTEND=noninteractive
codename=$(. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}")
target=()
if [ "$codename" = bookworm ]; then
    bp=/etc/apt/sources.list.d/fluxswarm-backports.sources
    if [ ! -f "$bp" ]; then
        src=""
        for f in /etc/apt/sources.list.d/debian.sources /etc/apt/sources.list.d/*.sources; do
            [ -f "$f" ] || continue
            if grep -Eq '^Suites:.*\bbookworm\b' "$f"; then src=$f; break; fi
        done
        if [ -n "$src" ]; then
            # Take the first deb822 stanza whose Suites names plain 'bookworm' and point it at
            # bookworm-backports.
            awk 'BEGIN{RS=""; ORS="\n\n"} /\nSuites:[^\n]*[ \t]bookworm([ \t\n]|$)|^Suites:[^\n]*[ \t]bookworm([ \t\n]|$)/ && !done {print; done=1}' "$src" \
                | sed -E 's/^Suites:.*/Suites: bookworm-backports/' | $SUDO tee "$bp" >/dev/null
        elif grep -Eqs '^deb .* bookworm main' /etc/apt/sources.list; then
            grep -E '^deb .* bookworm main' /etc/apt/sources.list | head -n 1 \
                | sed -E 's/ bookworm main.*/ bookworm-backports main/' | $SUDO tee "${bp%.sources}.list" >/dev/null
        fi
    fi
    target=(-t bookworm-backports)
fi

log "installing the Vulkan loader and Mesa lavapipe ${target[*]:-}"
$SUDO apt-get update -qq || log "apt-get update reported errors (continuing)"
if ! $SUDO apt-get install -y -qq "${target[@]}" libvulkan1 mesa-vulkan-drivers >/dev/null; then
    log "backports install failed; falling back to the distribution's Mesa"
    $SUDO apt-get install -y -qq libvulkan1 mesa-vulkan-drivers >/dev/null
fi
log "mesa-vulkan-drivers $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)"
