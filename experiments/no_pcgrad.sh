#!/usr/bin/env bash
# The ablation: the three actor gradients averaged, unprojected (train --no-pcgrad).
# Usage: bash experiments/no_pcgrad.sh [STEPS] [SEED] [OUT]   (defaults 108000, 1,
#        runs/experiments/no-pcgrad/seed<SEED>). Re-running continues the run with --resume.
source "$(dirname "$0")/common.sh"
steps=${1:-108000}
seed=${2:-1}
out=${3:-runs/experiments/no-pcgrad/seed$seed}
train_run "$out" "$seed" "$steps" "${ENVS:-4}" --no-pcgrad
