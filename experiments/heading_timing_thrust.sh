#!/usr/bin/env bash
# Does timing help the one-wall heading at low thrust? (issue 19; docs/controllability.md, "The
# thrust axis", follow-up registered 2026-12-05 before it ran.) The search of
# experiments/heading_timing.sh (the same seven candidates of `scripted-heading` on training
# seed 1001, 12 episodes each) at flow scale 0.85 and 637.5 nN on the refined grid, where
# `scripted-heading:45:75:0.9:0.15` got 3 of 10 and every constant at most 2. Then, unless the
# search picks the constant heading or the candidate already checked, the chosen candidate on
# the refined band's starts at that point (seed 2, 10 episodes), beside the cell's others.
# Usage: bash experiments/heading_timing_thrust.sh [TUNE_OUT] [THRUST_OUT]
#   (defaults runs/experiments/tune_scripted_heading_637 and runs/experiments/heading_thrust)
source "$(dirname "$0")/common.sh"
here="$(dirname "$0")"
tune=${1:-runs/experiments/tune_scripted_heading_637}
cells=${2:-runs/experiments/heading_thrust}
FINE=(--set domain.nx=2000 --set domain.ny=40 --set time.substeps=40)
TUNE_FAMILY=scripted-heading TUNE_SCALE=0.85 TUNE_THRUST=6.375e-7 TUNE_CONSTANTS="45" \
    TUNE_CALMS="30 45" TUNE_STORMS="60 75 90" TUNE_WINDOW="0.9 0.15" TUNE_STARTS=0.9 \
    TUNE_ENDS=0.15 TUNE_SET="${FINE[*]}" bash "$here/tune_scripted.sh" "$tune"
best=$(tune_best "$tune/scores.txt" | cut -d' ' -f1)
IFS=, read -r calm storm start end <<<"${best#scripted-heading:}"
if [ "$calm" = "$storm" ]; then
    echo "the search picked the constant heading $calm: no check"
    exit 0
fi
CHECK_EPISODES=10 CHECK_SEED=2 CHECK_POLICIES="scripted-heading:$calm:$storm:$start:$end" \
    bash "$here/frontier_check.sh" configs/frontier-095.toml "$cells/s0.85_f637.5" \
    "${FINE[@]}" --set inlet.scale=0.85 --set swarm.max_thrust_n=637.5e-9
