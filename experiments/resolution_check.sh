#!/usr/bin/env bash
# Resolution check: the passive swarm's displacement over the first systole and the pressure
# drop along the channel, at the paper's grid and at dx/2, dt/2 (examples/resolution_check.rs).
# Prints a markdown table. Usage: bash experiments/resolution_check.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-vulkan.sh
export NODEVICE_SELECT="${NODEVICE_SELECT:-1}"
cargo run --release --quiet --example resolution_check
