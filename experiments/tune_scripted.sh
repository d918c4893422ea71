#!/usr/bin/env bash
# Direct search for the `scripted` controller's four parameters (src/env/policy.rs) on
# training seeds only: every candidate runs K episodes (default 12, random phase and jitter)
# at the tuning scenario (default inlet.scale 0.95, max thrust 850 nN) with seed TUNE_SEED
# (default 1001; evaluation seeds are below 1000). Stage 1 crosses the calm and storm angles
# with the window [0.95 s, 0.2 s); stage 2 moves the window around the best pair.
# Usage: bash experiments/tune_scripted.sh [OUT]   (default runs/experiments/tune_scripted)
# Prints one line per candidate: successes, mean steps, mean final x_COM.
source "$(dirname "$0")/common.sh"
out=${1:-runs/experiments/tune_scripted}
K=${TUNE_EPISODES:-12}
SEED=${TUNE_SEED:-1001}
SCALE=${TUNE_SCALE:-0.95}
THRUST=${TUNE_THRUST:-8.5e-7}
mkdir -p "$out"

score() { # DIR -> "successes mean_steps mean_final_x"
    awk -F, 'NR > 1 { n++; s += ($4 == "success"); t += $3; x += $12 }
        END { printf "%d %.1f %.2f\n", s, t / n, x / n }' "$1/episodes.csv"
}
run() { # CALM STORM START END
    local p="$1,$2,$3,$4" dir="$out/scripted_$1_$2_$3_$4"
    episodes_once "$dir" "$K" --policy "scripted:$p" --envs 4 --seed "$SEED" \
        "${SCENARIO_SET[@]}" --set "inlet.scale=$SCALE" --set "swarm.max_thrust_n=$THRUST"
    echo "scripted:$p $(score "$dir")" | tee -a "$out/scores.txt"
}
: >"$out/scores.txt"
for calm in 0 20 40; do
    for storm in 45 60 75 90; do
        run "$calm" "$storm" 0.95 0.2
    done
done
best=$(sort -k2,2nr -k3,3nr "$out/scores.txt" | head -1 | cut -d' ' -f1 | cut -d: -f2)
IFS=, read -r calm storm _ _ <<<"$best"
for start in 0.9 0.95 0.0; do
    for end in 0.15 0.2 0.3; do
        run "$calm" "$storm" "$start" "$end"
    done
done
say "best: $(sort -k2,2nr -k3,3nr "$out/scores.txt" | head -1)"
