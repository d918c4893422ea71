#!/usr/bin/env bash
# The thrust axis of the refined band (issue 19; docs/controllability.md, "The thrust axis").
# The band and the heading band varied the flow at 850 nN only. Points fixed 2026-12-05, before
# any controller ran at another thrust on the refined grid: flow scale 0.85 (the scenario's) at
# F_max x0.75 (637.5 nN) and x1.25 (1062.5 nN), the protocol's thrust neighbours, on the refined
# grid with the band's seed (2), episodes (10) and starts. Order: `heading:45` then `scripted`
# at 637.5 nN, the same at 1062.5 nN, then the tuned `scripted-heading:45:75:0.9:0.15` at
# 637.5 and 1062.5 nN. The scripted controllers keep the parameters tuned at 850 nN.
# Usage: bash experiments/heading_thrust.sh [OUT]   (default runs/experiments/heading_thrust)
set -euo pipefail
here="$(dirname "$0")"
out=${1:-runs/experiments/heading_thrust}
export CHECK_EPISODES=${BAND_EPISODES:-10} CHECK_SEED=2
FINE=(--set domain.nx=2000 --set domain.ny=40 --set time.substeps=40 --set inlet.scale=0.85)
cell() { # cell F_NEWTON LABEL POLICIES
    CHECK_POLICIES="$3" bash "$here/frontier_check.sh" configs/frontier-095.toml \
        "$out/s0.85_f$2" "${FINE[@]}" --set "swarm.max_thrust_n=$1"
}
cell 637.5e-9 637.5 "heading:45 scripted"
cell 1062.5e-9 1062.5 "heading:45 scripted"
cell 637.5e-9 637.5 "scripted-heading:45:75:0.9:0.15"
cell 1062.5e-9 1062.5 "scripted-heading:45:75:0.9:0.15"
# Follow-up, fixed 2026-12-05 10:20 UTC after the cells above and before any of these ran: the
# other constants at 637.5 nN, where `scripted-heading` got 3 of 10 and `heading:45` none.
cell 637.5e-9 637.5 "heading:40 heading:50 heading:60 heading:75 wall-angle:40 wall"
