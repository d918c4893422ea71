#!/usr/bin/env bash
# Where is the frontier on the refined grid? (issue 16 item 4, docs/controllability.md.) The
# physics check found that `frontier-095` fails for every controller on a grid refined 2x in
# x, y and t, so this probe looks for headway on that grid (nx 2000, ny 40, substeps 40) at
# two candidate points fixed before any result (2026-12-02): the flow scaled down to 0.8 at
# 850 nN, and the thrust raised 1.5x to 1.275 uN at flow scale 0.95. Controllers: `scripted`
# (the phase-aware positive control) and `wall-angle:40` (the best constant controller at
# `frontier-095` on the paper grid), plus `upstream` at the raised thrust. REFINED_EPISODES
# episodes each (default 10; seed 2, as the frontier check), through experiments/frontier_check.sh.
# Added 2026-12-02 ~18:55 UTC, after the first point (both controllers succeed at scale 0.8):
# scale 0.875 at 850 nN, the midpoint towards 0.95, run before the raised-thrust point.
# Added 2026-12-02 ~20:08 UTC, after all three (the threshold lies between 0.8 and 0.875):
# scale 0.85 at 850 nN.
# Usage: bash experiments/frontier_refined.sh [OUT]   (default runs/experiments/frontier_refined)
set -euo pipefail
here="$(dirname "$0")"
out=${1:-runs/experiments/frontier_refined}
export CHECK_EPISODES=${REFINED_EPISODES:-10}
FINE=(--set domain.nx=2000 --set domain.ny=40 --set time.substeps=40)
CHECK_POLICIES="scripted wall-angle:40" bash "$here/frontier_check.sh" configs/frontier-095.toml \
    "$out/s0.80_f850" "${FINE[@]}" --set inlet.scale=0.8
CHECK_POLICIES="scripted wall-angle:40" bash "$here/frontier_check.sh" configs/frontier-095.toml \
    "$out/s0.875_f850" "${FINE[@]}" --set inlet.scale=0.875
CHECK_POLICIES="scripted upstream wall-angle:40" bash "$here/frontier_check.sh" \
    configs/frontier-095.toml "$out/s0.95_f1275" "${FINE[@]}" --set swarm.max_thrust_n=1.275e-6
CHECK_POLICIES="scripted wall-angle:40" bash "$here/frontier_check.sh" configs/frontier-095.toml \
    "$out/s0.85_f850" "${FINE[@]}" --set inlet.scale=0.85
