#!/usr/bin/env bash
# Constants at the named variant's neighbours (issue 19, item 2; docs/experiments.md, the bullet
# "Constants at the neighbours"). Declared 2026-12-07, before any of it ran: the protocol's neighbour runs
# give a policy's rate at flow scale x0.9 and x1.1 and thrust x0.75 and x1.25, but no constant
# was run there with the protocol's seed, so "holds up" could not be told from "the neighbour is
# easier". This runs `heading:45` (the constant of the heading band and of the thrust axis)
# and `wall-angle:40` (the best wall angle) at each of the four neighbours, with the neighbours'
# seed (201), episodes (40) and environments (4), in the frontier scenario
# (configs/frontier-fine-085.toml) with one change each. It changes nothing in the registered
# protocol. A finished rollout is kept; one cut off starts again. The committed ones
# (assets/results/frontier_learners/neighbour_constants/<change>/<policy>: config.toml,
# episodes.csv, starts.csv) are copied into OUT first, so a fresh checkout does not rerun them.
# Usage: bash experiments/neighbour_constants.sh [OUT]
#   (default runs/frontier-learners/neighbour-constants)
here="$(dirname "$0")"
source "$here/common.sh"
out=${1:-runs/frontier-learners/neighbour-constants}
export CHECK_EPISODES=40 CHECK_SEED=201
kept="$ROOT/assets/results/frontier_learners/neighbour_constants"
for kept_run in "$kept"/*/*; do
    rel=${kept_run#"$kept"/}
    [ -e "$out/$rel" ] || copy_complete "$kept_run" "$out/$rel" "$CHECK_EPISODES" starts.csv
done
# Both constants in one check per neighbour, so that the check's closing `map` reads only
# finished rollouts (a rollout cut off is redone before it).
for change in "${NEIGHBOURS[@]}"; do
    CHECK_POLICIES="heading:45 wall-angle:40" bash "$here/frontier_check.sh" \
        configs/frontier-fine-085.toml "$out/$change" --set "${NEIGHBOUR_SET[$change]}"
done
