#!/usr/bin/env bash
# The controllability map (issue 16, docs/experiments.md "The controllability map"): every
# controller at every point of flow scale x thrust bound, MAP_EPISODES episodes each (default
# 20, random phase and start jitter, quota per environment over MAP_ENVS = 4 environments),
# seed MAP_SEED (default 1; the scripted controller was tuned on seeds above 1000). Then one
# wall-drag probe per flow scale (a member pinned at the lower wall, zero thrust, one cycle) and
# `fluxswarm-gpu map`, which writes the CSVs and heatmaps into MAP_RESULTS (default
# assets/results). The rollouts (episodes.csv, starts.csv and config.toml only, a few KB each)
# are written under assets/results/controllability_map/ and committed, so a clean checkout
# resumes the map: finished rollouts are skipped. Points run thrust by thrust, from the
# highest flow scale down, so the frontier band comes first. MAP_SET adds rollout flags to
# every rollout and probe (e.g. the refined grid: MAP_SET="--set domain.nx=2000 --set
# domain.ny=40 --set time.substeps=40").
# Usage: bash experiments/controllability_map.sh [OUT]   (default assets/results/controllability_map)
source "$(dirname "$0")/common.sh"
out=${1:-assets/results/controllability_map}
read -r -a scales <<<"${MAP_SCALES:-1.0 0.9 0.8 0.7 0.6 0.5}"
read -r -a thrusts <<<"${MAP_THRUSTS:-8.5e-7 2.5e-6 8.5e-6}"
read -r -a policies <<<"${MAP_POLICIES:-zero random upstream wall-angle:30 wall wall-angle:60 scripted}"
K=${MAP_EPISODES:-20}
ENVS=${MAP_ENVS:-4}
SEED=${MAP_SEED:-1}
results=${MAP_RESULTS:-assets/results}
read -r -a extra <<<"${MAP_SET:-}"
mkdir -p "$out/wall_drag"

for s in "${scales[@]}"; do
    dir="$out/wall_drag/s$s"
    if [ ! -s "$dir/trajectories.csv" ]; then
        say "wall-drag probe at scale $s"
        rm -rf "$dir"
        fluxswarm rollout --policy zero --envs 1 --episodes 1 --seed "$SEED" --out "$dir" \
            --set solver.backend=native --set "inlet.scale=$s" --set swarm.count=1 \
            --set swarm.layout=explicit --set "swarm.positions_m=[[0.05, 0.00025]]" \
            --set "swarm.pinned=[0]" --set env.max_steps=200 "${extra[@]}" >/dev/null
    fi
done
for f in "${thrusts[@]}"; do
    for s in "${scales[@]}"; do
        for p in "${policies[@]}"; do
            episodes_once "$out/s${s}_f$f/${p//:/-}" "$K" --policy "$p" --envs "$ENVS" \
                --seed "$SEED" "${SCENARIO_SET[@]}" --set "inlet.scale=$s" \
                --set "swarm.max_thrust_n=$f" "${extra[@]}" || true
        done
    done
done
fluxswarm map "$out" --out "$results"
