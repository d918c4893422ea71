#!/usr/bin/env bash
# One Markdown row per run of a committed learner sweep (issue 19; experiments/frontier_learners.sh
# `results` stage): the protocol's two evaluations of the final policy (successes of the episodes,
# mean episode length in control steps and simulated seconds, mean progress), and the run's
# training episodes with how many succeeded. Read from RESULTS/eval/RUN/{deterministic,sampled}/
# episodes.csv and RESULTS/runs/RUN/episodes.csv; an evaluation not yet committed shows as "—".
# Usage: bash experiments/per_run_table.sh [RESULTS] (default assets/results/frontier_learners)
set -euo pipefail
results=${1:-assets/results/frontier_learners}
[ -d "$results/eval" ] || { echo "no $results/eval: give a results directory written by experiments/frontier_learners.sh (results stage)" >&2; exit 2; }

# awk prologue: c[NAME] is the column of NAME in the CSV's header (SPEC section 7 names them).
by_name='NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next } '

# "successes/episodes | steps (seconds) | progress" of an evaluation's episodes.csv.
evaluation() {
    local csv=$1 dt=$2
    [ -f "$csv" ] || { echo "— | — | —"; return; }
    awk -F, -v dt="$dt" "$by_name"'NR > 1 { n++; k += ($c["outcome"] == "success"); steps += $c["steps"]; p += $c["progress"] }
        END { printf "%d/%d | %.2f (%.3f s) | %.1f", k, n, steps / n, steps / n * dt, p / n }' "$csv"
}

echo "| variant | seed | mean action: success | steps (s) | progress | sampled: success | steps (s) | progress | training episodes (successes) |"
echo "|---|---|---|---|---|---|---|---|---|"
for dir in "$results"/eval/p*_seed*; do
    run=$(basename "$dir")
    variant=$((10#${run:1:3}))
    seed=${run##*_seed}
    config=$(ls "$dir"/*/config.toml | head -n 1)
    dt=$(awk -F' = ' '/^control_dt_s/ { print $2 }' "$config")
    training="—"
    if [ -f "$results/runs/$run/episodes.csv" ]; then
        training=$(awk -F, "$by_name"'NR > 1 { n++; k += ($c["outcome"] == "success") }
            END { printf "%d (%d)", n, k }' "$results/runs/$run/episodes.csv")
    fi
    echo "$variant $seed| $variant | $seed | $(evaluation "$dir/deterministic/episodes.csv" "$dt") | $(evaluation "$dir/sampled/episodes.csv" "$dt") | $training |"
done | sort -k1,1n -k2,2n | cut -d'|' -f2- | sed 's/^/|/'
