#!/usr/bin/env bash
# Every paper experiment at one budget, then the report:
#   baselines (direct-upstream, wall-hugging), MOMAPPO with PCGrad and the no-PCGrad ablation for
#   each seed, before/after rollouts of the first seed's MOMAPPO run, and
#   `fluxswarm-gpu report` over all of it (figures and report.md in OUT/report), and the
#   resolution check (experiments/resolution_check.sh, a few minutes; appended to report.md).
# Usage: bash experiments/run_all.sh [--steps N] [--seeds K] [--envs E] [--out DIR] [--no-resolution] [--native]
#   defaults: the paper's budget N = 108000 global steps (4 envs x 27,000), K = 3 seeds (1..K),
#   E = 4, DIR = runs/experiments. Interrupt it at any time: re-running the same command
#   continues every unfinished run (train --resume) and skips finished stages; a larger --steps
#   extends the runs. --native (or FLUXSWARM_BACKEND=native) runs new training runs and the
#   baselines with the native CPU backend, 2.5-3x faster training without a GPU.
source "$(dirname "$0")/common.sh"
here="$(dirname "$0")"
steps=108000 seeds=3 out=runs/experiments resolution=1
while [ $# -gt 0 ]; do
    case $1 in
        --steps) steps=$2; shift 2 ;;
        --seeds) seeds=$2; shift 2 ;;
        --envs) export ENVS=$2; shift 2 ;;
        --out) out=$2; shift 2 ;;
        --no-resolution) resolution=0; shift ;;
        --native) export FLUXSWARM_BACKEND=native; BACKEND_SET=(--set solver.backend=native); shift ;;
        -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
        *) echo "run_all.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done
mkdir -p "$out"
if [ -z "${FLUXSWARM_BIN:-}" ]; then
    bash "$ROOT/scripts/install-vulkan.sh"
    (cd "$ROOT" && cargo build --release --quiet)
    export FLUXSWARM_BIN="$ROOT/target/release/fluxswarm-gpu"
fi
export FLUXSWARM_BIN
start=$(date +%s)
bash "$here/baselines.sh" "$out/baselines"
runs=() ablation=()
for seed in $(seq 1 "$seeds"); do
    bash "$here/momappo.sh" "$steps" "$seed" "$out/momappo/seed$seed"
    bash "$here/no_pcgrad.sh" "$steps" "$seed" "$out/no-pcgrad/seed$seed"
    runs+=("$out/momappo/seed$seed") ablation+=("$out/no-pcgrad/seed$seed")
done
bash "$here/before_after.sh" "$out/momappo/seed1" "$out/momappo/before-after"
if [ "$resolution" = 1 ] && [ ! -s "$out/resolution_check.md" ]; then
    say "resolution check (paper grid and dx/2, dt/2)"
    bash "$here/resolution_check.sh" > "$out/resolution_check.md.part"
    mv "$out/resolution_check.md.part" "$out/resolution_check.md"
fi
say "report"
fluxswarm report "${runs[@]}" --compare "${ablation[@]}" \
    --baseline "$out/baselines/upstream" --baseline "$out/baselines/wall" \
    --before "$out/momappo/before-after/before" --after "$out/momappo/before-after/after" \
    --out "$out/report"
if [ -s "$out/resolution_check.md" ]; then
    printf '\n## Resolution check (experiments/resolution_check.sh)\n\n' >> "$out/report/report.md"
    cat "$out/resolution_check.md" >> "$out/report/report.md"
fi
say "all experiments done in $(( $(date +%s) - start )) s: $out/report/report.md"
