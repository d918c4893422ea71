#!/usr/bin/env bash
# The one-wall headings across the refined band (issue 19; docs/controllability.md, "The
# one-wall headings on the refined band"). `heading:45` (every member towards the upper wall at
# 45 degrees from upstream) beat every controller of the protocol in `frontier-fine-085` (35/40
# at seed 201, against `scripted` 30/40), so the refined grid's frontier, found with the
# wall-angle family alone, may lie elsewhere for it. Points fixed 2026-12-05 06:21 UTC, before
# any heading ran off `frontier-fine-085`: flow scales 0.85, 0.875, 0.925 and 1.0 at 850 nN, in
# that order, on the refined grid (nx 2000, ny 40, 40 substeps), with the refined band's seed (2),
# episodes (10) and starts (experiments/frontier_refined.sh), so each cell pairs with the band's
# `scripted`, `wall` and `wall-angle:40` at 0.85 and 0.875.
# Usage: bash experiments/heading_band.sh [OUT]   (default runs/experiments/heading_band)
set -euo pipefail
here="$(dirname "$0")"
out=${1:-runs/experiments/heading_band}
export CHECK_EPISODES=${BAND_EPISODES:-10} CHECK_SEED=2
FINE=(--set domain.nx=2000 --set domain.ny=40 --set time.substeps=40)
for s in 0.85 0.875 0.925 1.0; do
    CHECK_POLICIES="heading:45" bash "$here/frontier_check.sh" configs/frontier-095.toml \
        "$out/s${s}_f850" "${FINE[@]}" --set "inlet.scale=$s"
done
