#!/usr/bin/env bash
# The paper's two baselines (direct-upstream, wall-hugging) under the evaluation protocol:
# EVAL_ENVS environments, EVAL_EPISODES episodes, seed EVAL_SEED (defaults 4, 8, 1).
# Usage: bash experiments/baselines.sh [OUT]   (default runs/experiments/baselines)
source "$(dirname "$0")/common.sh"
out=${1:-runs/experiments/baselines}
for policy in upstream wall; do
    rollout_once "$out/$policy" --policy "$policy" --envs "$EVAL_ENVS" \
        --episodes "$EVAL_EPISODES" --seed "$EVAL_SEED" "${BACKEND_SET[@]}"
done
