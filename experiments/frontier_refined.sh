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
# Added 2026-12-03 ~08:00 UTC, after the refined-grid tuning of `scripted` at 0.875 (seed 1001:
# no switching candidate beat the constant 40 degrees, all at most 1 of 12): every other
# constant controller of the map (zero, random, upstream, 30 degrees, wall, 60 degrees) at the
# three 850 nN points, 0.875 first, so each point's best constant is known on the refined grid.
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
for s in 0.875 0.85 0.80; do
    CHECK_POLICIES="zero random upstream wall-angle:30 wall wall-angle:60" \
        bash "$here/frontier_check.sh" configs/frontier-095.toml "$out/s${s}_f850" "${FINE[@]}" \
        --set "inlet.scale=$s"
done
