#!/usr/bin/env bash
# Before/after rollouts of one trained run, acting with the mean action, under the evaluation
# protocol: "before" is the same seed's untrained policy (train --steps 0 writes its update-0
# checkpoint), "after" is the run's newest checkpoint. Both write swarm.csv for the dispersion
# and centre-of-mass figures of `report --before/--after`.
# Usage: bash experiments/before_after.sh RUN_DIR [OUT]   (default OUT: RUN_DIR/../before-after)
source "$(dirname "$0")/common.sh"
run=${1:?usage: before_after.sh RUN_DIR [OUT]}
out=${2:-$(dirname "$run")/before-after}
seed=$(run_seed "$run")
if ! compgen -G "$out/untrained/checkpoints/update-*.safetensors" >/dev/null; then
    rm -rf "$out/untrained"
    say "untrained policy of seed $seed"
    fluxswarm train --envs "${ENVS:-4}" --seed "$seed" --steps 0 --out "$out/untrained" \
        $(grep -q '^pcgrad = false' "$run/config.toml" && echo --no-pcgrad) >/dev/null
fi
# A run extended since its "after" rollout (a larger --steps) gets a new one.
newest=$(ls "$run"/checkpoints/update-*.safetensors | tail -n 1)
if [ -s "$out/after/episodes.csv" ] && [ "$newest" -nt "$out/after/episodes.csv" ]; then
    say "$run has a newer checkpoint than its after-learning rollout: redoing it"
    rm -rf "$out/after"
fi
for which in before after; do
    ck=$run
    [ "$which" = before ] && ck=$out/untrained
    rollout_once "$out/$which" --policy "$ck" --deterministic --envs "$EVAL_ENVS" \
        --episodes "$EVAL_EPISODES" --seed "$EVAL_SEED"
done
