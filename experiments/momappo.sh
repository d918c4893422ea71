#!/usr/bin/env bash
# The paper's main experiment: MOMAPPO with PCGrad at the paper's setup.
# Usage: bash experiments/momappo.sh [STEPS] [SEED] [OUT]   (defaults 108000 = 4 x 27,000, 1,
#        runs/experiments/momappo/seed<SEED>). Re-running continues the run with --resume.
source "$(dirname "$0")/common.sh"
steps=${1:-108000}
seed=${2:-1}
out=${3:-runs/experiments/momappo/seed$seed}
train_run "$out" "$seed" "$steps" "${ENVS:-4}"
