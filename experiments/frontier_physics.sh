#!/usr/bin/env bash
# Is the frontier physical or numerical? (issue 16 item 4, docs/controllability.md.) Re-runs
# controllers of a frontier scenario at half the grid spacing and half the substep
# (nx x2, ny x2, substeps x2: dx/2, dy/2, dt_sub/2, about 8x the cost of a step) and with the
# empirical drag off (swarm.drag = false), PHYS_EPISODES episodes each (default 20), seed
# PHYS_SEED (default 2, as the frontier check, whose runs are the base case).
# Usage: bash experiments/frontier_physics.sh CONFIG [OUT]
#   (default OUT runs/experiments/frontier_physics/<config name>)
source "$(dirname "$0")/common.sh"
config=${1:?usage: frontier_physics.sh configs/frontier-X.toml [OUT]}
name=$(basename "$config" .toml)
out=${2:-runs/experiments/frontier_physics/$name}
K=${PHYS_EPISODES:-20}
SEED=${PHYS_SEED:-2}
read -r -a policies <<<"${PHYS_POLICIES:-wall scripted}"
nx=$(sed -n -E 's/^nx = ([0-9]+).*/\1/p' "$config")
ny=$(sed -n -E 's/^ny = ([0-9]+).*/\1/p' "$config")
sub=$(sed -n -E 's/^substeps = ([0-9]+).*/\1/p' "$config")
for p in "${policies[@]}"; do
    episodes_once "$out/nodrag/${p//:/-}" "$K" --config "$config" --policy "$p" --envs 4 \
        --seed "$SEED" --set swarm.drag=false || true
    episodes_once "$out/fine/${p//:/-}" "$K" --config "$config" --policy "$p" --envs 4 \
        --seed "$SEED" --set "domain.nx=$((2 * nx))" --set "domain.ny=$((2 * ny))" \
        --set "time.substeps=$((2 * sub))" || true
done
for v in nodrag fine; do
    fluxswarm map "$out/$v" --out "$out/$v"
done
