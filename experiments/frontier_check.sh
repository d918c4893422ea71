#!/usr/bin/env bash
# The pre-registered check of a frontier scenario (docs/controllability.md, "Protocol"): every
# comparator (zero, random, upstream, wall, the map's best wall angles, scripted) for
# CHECK_EPISODES episodes (default 40) over 4 environments, seed CHECK_SEED (default 2: the map
# used seed 1 and the scripted tuning seeds above 1000, so the check is on fresh starts).
# Usage: bash experiments/frontier_check.sh CONFIG [OUT] [EXTRA rollout flags...]
#   (default OUT runs/experiments/frontier_check/<config name>)
source "$(dirname "$0")/common.sh"
config=${1:?usage: frontier_check.sh configs/frontier-X.toml [OUT] [flags...]}
name=$(basename "$config" .toml)
out=${2:-runs/experiments/frontier_check/$name}
shift $(($# < 2 ? $# : 2))
K=${CHECK_EPISODES:-40}
SEED=${CHECK_SEED:-2}
read -r -a policies <<<"${CHECK_POLICIES:-zero random upstream wall-angle:20 wall wall-angle:70 scripted}"
for p in "${policies[@]}"; do
    episodes_once "$out/${p//:/-}" "$K" --config "$config" --policy "$p" --envs 4 \
        --seed "$SEED" "$@" || true
done
fluxswarm map "$out" --out "$out"
