#!/usr/bin/env bash
# Shared by the experiment scripts: set-up (the software Vulkan driver when there is no GPU
# driver, a release build) and the helpers that make every experiment resumable: a stage whose
# output is complete is skipped, a training run that stopped part-way continues with --resume.
# Set FLUXSWARM_BIN to run a prebuilt binary instead of building one.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export NODEVICE_SELECT="${NODEVICE_SELECT:-1}"

# The binary every script runs, built (and the driver installed) on first use.
fluxswarm() {
    if [ -z "${FLUXSWARM_BIN:-}" ]; then
        bash "$ROOT/scripts/install-vulkan.sh"
        (cd "$ROOT" && cargo build --release --quiet)
        FLUXSWARM_BIN="$ROOT/target/release/fluxswarm-gpu"
    fi
    "$FLUXSWARM_BIN" "$@"
}

# FLUXSWARM_BACKEND=native|adapter|auto: the backend of new training runs and the baseline
# rollouts (default: the configuration's, `auto`: a GPU if there is one, else the CPU backend;
# docs/architecture.md). Resumed runs and rollouts of a checkpoint keep the backend saved with it.
BACKEND_SET=()
if [ -n "${FLUXSWARM_BACKEND:-}" ]; then
    BACKEND_SET=(--set "solver.backend=$FLUXSWARM_BACKEND")
fi

say() { echo "== $(date -u +%H:%M:%S) $*" >&2; }

# tune_best SCORES: the best line of a tune_scripted.sh scores.txt ("CANDIDATE SUCCESSES
# MEAN_STEPS MEAN_X"): the most successes, then the longer mean episode.
tune_best() { sort -k2,2nr -k3,3nr "$1" | head -1; }

# train_run DIR SEED STEPS ENVS [train flags...]: trains into DIR, or continues DIR up to STEPS.
train_run() {
    local dir=$1 seed=$2 steps=$3 envs=$4
    shift 4
    if compgen -G "$dir/checkpoints/update-*.safetensors" >/dev/null; then
        say "train $dir: continuing to $steps global steps"
        fluxswarm train --resume "$dir" --steps "$steps" >/dev/null
    else
        say "train $dir: seed $seed, $envs environments, $steps global steps $*"
        fluxswarm train --envs "$envs" --seed "$seed" --steps "$steps" --out "$dir" \
            "${BACKEND_SET[@]}" "$@" >/dev/null
    fi
}

# rollout_once DIR ARGS...: `rollout ARGS --out DIR` unless DIR already holds its episodes.csv.
rollout_once() {
    local dir=$1
    shift
    if [ -s "$dir/episodes.csv" ] && [ -s "$dir/swarm.csv" ]; then
        say "rollout $dir: done already"
        return
    fi
    rm -rf "$dir"
    say "rollout $dir: $*"
    fluxswarm rollout "$@" --out "$dir" >/dev/null
}

# The seed a train run was started with (from the header of its config.toml).
run_seed() {
    sed -n -E '1s/.* seed ([0-9]+),.*/\1/p' "$1/config.toml"
}

# Common flags of the evaluation protocol (baselines, before and after learning).
EVAL_ENVS=${EVAL_ENVS:-4}
EVAL_EPISODES=${EVAL_EPISODES:-8}
EVAL_SEED=${EVAL_SEED:-1}

# has_episodes DIR N: DIR holds N finished episodes (episodes.csv with N rows).
has_episodes() {
    [ -s "$1/episodes.csv" ] && [ "$(($(wc -l <"$1/episodes.csv") - 1))" -ge "$2" ]
}

# copy_complete SRC DST N [FILE...]: SRC's config.toml and episodes.csv, and each FILE named,
# into DST when SRC holds N episodes; nothing when it holds fewer.
copy_complete() {
    local src=$1 dst=$2 n=$3 f
    shift 3
    has_episodes "$src" "$n" || return 0
    mkdir -p "$dst"
    for f in config.toml episodes.csv "$@"; do cp "$src/$f" "$dst/"; done
}

# episodes_once DIR K ARGS...: `rollout ARGS --episodes K --no-traces --out DIR` unless DIR
# already holds all K episodes (episodes.csv with K rows).
episodes_once() {
    local dir=$1 k=$2
    shift 2
    has_episodes "$dir" "$k" && return
    rm -rf "$dir"
    mkdir -p "$(dirname "$dir")"
    say "rollout $dir: $*"
    fluxswarm rollout "$@" --episodes "$k" --no-traces --out "$dir" >/dev/null 2>"$dir.log" ||
        { say "rollout $dir failed: $(tail -1 "$dir.log")"; return 1; }
    rm -f "$dir.log"
}

# The scenario flags every map and frontier rollout shares: random start phase, start jitter
# of one cell (0.1 mm) in x and y, and the CPU backend (the same bits on every machine).
SCENARIO_SET=(--set inlet.random_phase=true --set env.position_jitter_m=1e-4
    --set solver.backend=native)

# The frontier scenario's four neighbours (issue 19, item 2: flow scale +-10 %, thrust +-25 %):
# NEIGHBOURS in the order they run, NEIGHBOUR_SET[name] the one --set each changes. The
# scenario's inlet.scale is 0.85 and its swarm.max_thrust_n 8.5e-7 (configs/frontier-fine-085.toml).
NEIGHBOURS=(scale-x0.9 scale-x1.1 thrust-x0.75 thrust-x1.25)
declare -gA NEIGHBOUR_SET=(
    [scale-x0.9]="inlet.scale=0.765" [scale-x1.1]="inlet.scale=0.935"
    [thrust-x0.75]="swarm.max_thrust_n=6.375e-7" [thrust-x1.25]="swarm.max_thrust_n=1.0625e-6"
)
