#!/usr/bin/env bash
# Does timing help the one-wall heading? (issue 19; docs/controllability.md, the section of that
# name, registered 2026-12-05 before it ran.) Stage 1: the direct search of
# experiments/tune_scripted.sh over `scripted-heading` at flow scale 1.0, 850 nN, on the refined
# grid and training seed 1001 (the constant heading 45, and calm 30 or 45 with storm 60, 75 or
# 90 in the window [0.9 s, 0.15 s)). Stage 2, the check on the refined band's starts (seed 2, 10
# episodes, as experiments/heading_band.sh): the chosen candidate at flow scales 1.0 and 0.925,
# then `scripted` at both, written beside the band's cells in BAND (skipped when the search
# picks the constant heading: switching did not help).
# Usage: bash experiments/heading_timing.sh [TUNE_OUT] [BAND]
#   (defaults runs/experiments/tune_scripted_heading and runs/experiments/heading_band)
source "$(dirname "$0")/common.sh"
here="$(dirname "$0")"
tune=${1:-runs/experiments/tune_scripted_heading}
band=${2:-runs/experiments/heading_band}
FINE=(--set domain.nx=2000 --set domain.ny=40 --set time.substeps=40)
TUNE_FAMILY=scripted-heading TUNE_SCALE=1.0 TUNE_CONSTANTS="45" TUNE_CALMS="30 45" \
    TUNE_STORMS="60 75 90" TUNE_WINDOW="0.9 0.15" TUNE_STARTS=0.9 TUNE_ENDS=0.15 \
    TUNE_SET="${FINE[*]}" bash "$here/tune_scripted.sh" "$tune"
best=$(tune_best "$tune/scores.txt" | cut -d' ' -f1)
IFS=, read -r calm storm start end <<<"${best#scripted-heading:}"
if [ "$calm" = "$storm" ]; then
    echo "the search picked the constant heading $calm: no check"
    exit 0
fi
export CHECK_EPISODES=10 CHECK_SEED=2
for p in "scripted-heading:$calm:$storm:$start:$end" scripted; do
    for s in 1.0 0.925; do
        CHECK_POLICIES="$p" bash "$here/frontier_check.sh" configs/frontier-095.toml \
            "$band/s${s}_f850" "${FINE[@]}" --set "inlet.scale=$s"
    done
done
