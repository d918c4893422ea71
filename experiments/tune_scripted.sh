#!/usr/bin/env bash
# Direct search for the `scripted` controller's four parameters (src/env/policy.rs) on
# training seeds only: every candidate runs K episodes (default 12, random phase and jitter)
# at the tuning scenario (default inlet.scale 0.95, max thrust 850 nN) with seed TUNE_SEED
# (default 1001; evaluation seeds are below 1000). Stage 1 crosses the calm angles TUNE_CALMS
# with the storm angles TUNE_STORMS over the window TUNE_WINDOW (default [0.95 s, 0.2 s));
# stage 2 moves the window (TUNE_STARTS x TUNE_ENDS) around the best pair. A candidate with
# CALM = STORM is a constant wall angle, so a grid that holds some compares switching with
# constant thrust on the same episodes; TUNE_CONSTANTS (default none) adds such candidates
# for the angles it lists. TUNE_SET adds rollout flags to every candidate (e.g.
# the refined grid: TUNE_SET="--set domain.nx=2000 --set domain.ny=40 --set time.substeps=40").
# TUNE_FAMILY (default scripted) picks the controller: `scripted` (angles towards each member's
# nearer wall) or `scripted-heading` (one heading for every member, towards the upper wall).
# Usage: bash experiments/tune_scripted.sh [OUT]   (default runs/experiments/tune_scripted)
# Prints one line per candidate: successes, mean steps, mean final x_COM.
source "$(dirname "$0")/common.sh"
out=${1:-runs/experiments/tune_scripted}
K=${TUNE_EPISODES:-12}
SEED=${TUNE_SEED:-1001}
SCALE=${TUNE_SCALE:-0.95}
THRUST=${TUNE_THRUST:-8.5e-7}
read -r -a calms <<<"${TUNE_CALMS:-0 20 40}"
read -r -a storms <<<"${TUNE_STORMS:-45 60 75 90}"
read -r -a window <<<"${TUNE_WINDOW:-0.95 0.2}"
read -r -a starts <<<"${TUNE_STARTS:-0.9 0.95 0.0}"
read -r -a ends <<<"${TUNE_ENDS:-0.15 0.2 0.3}"
read -r -a constants <<<"${TUNE_CONSTANTS:-}"
read -r -a extra <<<"${TUNE_SET:-}"
FAMILY=${TUNE_FAMILY:-scripted}
mkdir -p "$out"

score() { # DIR -> "successes mean_steps mean_final_x"
    awk -F, 'NR > 1 { n++; s += ($4 == "success"); t += $3; x += $12 }
        END { printf "%d %.1f %.2f\n", s, t / n, x / n }' "$1/episodes.csv"
}
run() { # CALM STORM START END
    local p="$1,$2,$3,$4" dir="$out/${FAMILY}_$1_$2_$3_$4"
    episodes_once "$dir" "$K" --policy "$FAMILY:$p" --envs 4 --seed "$SEED" \
        "${SCENARIO_SET[@]}" --set "inlet.scale=$SCALE" --set "swarm.max_thrust_n=$THRUST" \
        "${extra[@]}"
    # The window stage runs the best pair's window again when it is the stage-1 window: score
    # each candidate once.
    grep -q "^$FAMILY:$p " "$out/scores.txt" || echo "$FAMILY:$p $(score "$dir")" | tee -a "$out/scores.txt"
}
: >"$out/scores.txt"
for angle in "${constants[@]}"; do
    run "$angle" "$angle" "${window[0]}" "${window[1]}"
done
for calm in "${calms[@]}"; do
    for storm in "${storms[@]}"; do
        run "$calm" "$storm" "${window[0]}" "${window[1]}"
    done
done
best=$(tune_best "$out/scores.txt" | cut -d' ' -f1 | cut -d: -f2)
IFS=, read -r calm storm _ _ <<<"$best"
if [ "$calm" = "$storm" ]; then # a constant angle: the window changes nothing
    starts=()
fi
for start in "${starts[@]}"; do
    for end in "${ends[@]}"; do
        run "$calm" "$storm" "$start" "$end"
    done
done
say "best: $(tune_best "$out/scores.txt")"
