#!/usr/bin/env bash
# Issue 19's protocol end to end (docs/controllability.md, "Protocol for learning at the
# frontier"). It is resumable: re-run it and it continues where it stopped. Finished stages
# and runs are kept, and a train run that stopped continues from its newest checkpoint.
#
# Usage: bash experiments/frontier_learners.sh [SWEEP_DIR]   (default runs/frontier-learners)
#
# FRONTIER_STAGES picks the stages, in this order (default all five):
# - train: the sweep experiments/sweeps/frontier-learners.toml, one run at a time in the
#   protocol's seed-major order (seed 1 of variants 0-7, then seed 2, ...), each run evaluated
#   (as the eval stage) as soon as it has finished. With FRONTIER_SLURM=1 it writes the Slurm
#   array and submits it instead, every run at once. With FRONTIER_EVAL=later it leaves the
#   evaluations to an eval-follow stage running beside it, so that training never waits for
#   them. A task listed in SWEEP_DIR/device-claims is skipped: scripts/device-sweep runs it on
#   a GPU machine.
#   Several train stages may run side by side: each takes the next task no other holds (flock
#   on SWEEP_DIR/logs/taskI.lock). On two cores, two of them with RAYON_NUM_THREADS=1 and
#   their own evaluations keep both cores busy without oversubscribing them
#   (docs/controllability.md, "Running it").
# - eval: every finished run, 40 episodes at seed 201 on 4 environments, once sampled and once
#   with the mean action. Output goes to SWEEP_DIR/eval/<run>/{sampled,deterministic}.
# - eval-follow (not in the default list): the eval stage again every 5 minutes until no run
#   is left to train or evaluate; the partner of FRONTIER_EVAL=later, e.g.
#   FRONTIER_STAGES="comparators eval-follow" beside FRONTIER_STAGES=train FRONTIER_EVAL=later.
#   An evaluation in progress is locked (flock on DIR.lock), so two processes never write one.
# - comparators: the nine comparators, 40 episodes at seed 201 (frontier_check.sh). Output
#   goes to SWEEP_DIR/comparators.
# - neighbours: the finished runs of the variants named in FRONTIER_NEIGHBOURS (point indices,
#   e.g. "3"; the protocol names the variant `report --frontier` ranks best once every run is
#   evaluated), sampled, 40 episodes at seed 201, at flow scale x0.9 and x1.1 and at F_max x0.75
#   and x1.25 (`rollout --policy RUN --set`, config::TRANSFER_KEYS). Without FRONTIER_NEIGHBOURS
#   the stage says so and skips. Output goes to SWEEP_DIR/neighbours/<run>/<change>. Each
#   rollout is locked as an evaluation is, so two processes running this stage share its work.
# - curve (not in the default list; exploratory, outside the protocol): each done run's policy
#   snapshots (`train --policy-every`, policies/update-N.safetensors) evaluated sampled at seed
#   201 with FRONTIER_CURVE_EPISODES (default 16) episodes on 4 environments (only the runs of
#   the points in FRONTIER_CURVE_POINTS, as FRONTIER_NEIGHBOURS, when it is set), into
#   SWEEP_DIR/curve/<run>/update-N: whether the evaluated policy rises and falls as the
#   training window does. The protocol's evaluation stays the final policy's.
# - report: `report --frontier` into SWEEP_DIR/report (frontier.md, frontier.csv): each
#   variant's pooled success rate and metrics per evaluation, with bootstrap 95 % intervals
#   over seeds, the comparators and the goal. It reads whatever has finished so far.
# - results (not in the default list): copies what has finished into FRONTIER_RESULTS (default
#   assets/results/frontier_learners), the results to commit: sweep.csv, each done run's
#   config.toml and training episodes.csv (runs/<run>/), and the config.toml and episodes.csv
#   of every complete evaluation, neighbour, curve point and comparator, in the layout `report --frontier`
#   reads, then runs the report there (FRONTIER_RESULTS/report). No checkpoint is copied. With
#   FRONTIER_CURVE_POINTS set, the policy snapshots of those points' done runs are kept too
#   (snapshots/<run>/update-N.safetensors, about 290 KB each), so the curve can be evaluated
#   again after a fresh checkout.
# - restore (not in the default list): the reverse of results, for a fresh checkout whose
#   SWEEP_DIR is gone (runs/ is not committed): every run FRONTIER_RESULTS/sweep.csv lists as
#   done gets its directory back (config.toml, episodes.csv, policy.safetensors where results
#   kept it) with a sweep-task.toml that says done, from the provenance columns; every
#   complete evaluation, neighbour, curve point and comparator is copied back, and every kept
#   snapshot goes back into its run's policies/. Nothing that
#   exists in SWEEP_DIR is overwritten, so it is safe to repeat. A restored run without a
#   policy cannot be evaluated again (the neighbours stage says so and goes on).
# The results stage also keeps each done run's policy.safetensors (about 280 KB; the actor and
# normaliser, no optimiser state), so that the neighbours stage and the named seed's policy
# survive a lost SWEEP_DIR.
source "$(dirname "$0")/common.sh"
cd "$ROOT"
S=${1:-runs/frontier-learners}
# The protocol's; other values are for trying the script on a small sweep.
SPEC=${FRONTIER_SPEC:-experiments/sweeps/frontier-learners.toml}
CONFIG=${FRONTIER_CONFIG:-configs/frontier-fine-085.toml}
K=${FRONTIER_EPISODES:-40}
KC=${FRONTIER_CURVE_EPISODES:-16}
SEED=201
read -r -a stages <<<"${FRONTIER_STAGES:-train eval comparators neighbours report}"

# The done runs' directories (relative to S), from a refreshed sweep.csv.
done_runs() {
    fluxswarm sweep --status --out "$S" >/dev/null
    awk -F, 'NR > 1 && $3 == "done" { print $4 }' "$S/sweep.csv"
}

# task_field I COLUMN: sweep.csv's COLUMN (3: status, 4: the run's directory) of task I.
task_field() {
    awk -F, -v r=$(($1 + 2)) -v c="$2" 'NR == r { print $c }' "$S/sweep.csv"
}

# train_task I: trains sweep task I unless another worker holds it (flock on
# logs/taskI.lock, released when this process exits or the task ends), so several train
# stages can run side by side, each taking the next free task. Fails when the task was not
# trained here (held elsewhere, stopped or failed).
train_task() {
    local i=$1 lock
    exec {lock}>"$S/logs/task$i.lock"
    flock -n "$lock" || { say "train: task $i is held by another worker"; exec {lock}>&-; return 1; }
    # It may have finished while this worker waited to open the lock.
    fluxswarm sweep --status --out "$S" >/dev/null
    if [ "$(task_field "$i" 3)" = done ]; then
        exec {lock}>&-
        return 0
    fi
    say "train: task $i"
    fluxswarm sweep --task "$i" --out "$S" >>"$S/logs/task$i.log" 2>&1 ||
        { say "train: task $i stopped or failed (see $S/logs/task$i.log)"; exec {lock}>&-; return 1; }
    exec {lock}>&-
    fluxswarm sweep --status --out "$S" >/dev/null
}

stage_train() {
    [ -s "$S/sweep.toml" ] || fluxswarm sweep "$SPEC" --out "$S" --slurm >/dev/null
    fluxswarm sweep --status --out "$S" >/dev/null
    if [ "${FRONTIER_SLURM:-0}" = 1 ]; then
        fluxswarm sweep --out "$S" --slurm --submit
        return
    fi
    # sweep.csv has a row per run, point-major (run index = point x seeds + seed index).
    local runs seeds s p i
    runs=$(($(wc -l <"$S/sweep.csv") - 1))
    seeds=$(awk -F, 'NR > 1 { print $2 }' "$S/sweep.csv" | sort -u | wc -l)
    for s in $(seq 0 $((seeds - 1))); do
        for p in $(seq 0 $((runs / seeds - 1))); do
            i=$((p * seeds + s))
            # A run done before (in an earlier session) is evaluated now if it was not yet:
            # eval_once skips complete evaluations.
            if [ "$(task_field "$i" 3)" != done ]; then
                if grep -qx "$i" "$S/device-claims" 2>/dev/null; then
                    say "train: task $i is claimed by a GPU machine (scripts/device-sweep); skipped until merged"
                    continue
                fi
                train_task "$i" || continue
            fi
            [ "${FRONTIER_EVAL:-now}" = later ] && continue
            [ "$(task_field "$i" 3)" != done ] || eval_run "$(task_field "$i" 4)"
        done
    done
}

# once_locked DIR N VERB ARGS...: `VERB ARGS --envs 4 --episodes N --seed SEED --no-traces
# --out DIR` (VERB: eval or rollout) unless DIR holds N episodes already or another process is
# on it (it holds DIR.lock, a file that stays; the lock is released when the process exits), so
# that two processes running the same stage share its work.
once_locked() {
    local dir=$1 n=$2 verb=$3 lock
    shift 3
    has_episodes "$dir" "$n" && return
    mkdir -p "$(dirname "$dir")"
    exec {lock}>"$dir.lock"
    flock -n "$lock" || { say "$verb $dir: another process is on it"; exec {lock}>&-; return 0; }
    # It may have finished while this process waited to open the lock.
    has_episodes "$dir" "$n" && { exec {lock}>&-; return; }
    rm -rf "$dir"
    say "$verb $dir: $*"
    fluxswarm "$verb" "$@" --envs 4 --episodes "$n" --seed "$SEED" --no-traces --out "$dir" \
        >/dev/null 2>"$dir.log" ||
        { say "$verb $dir failed: $(tail -1 "$dir.log")"; exec {lock}>&-; return 1; }
    rm -f "$dir.log"
    exec {lock}>&-
    has_episodes "$dir" "$n" || { say "$verb $dir: fewer than $n episodes written"; return 1; }
}

# eval_once DIR ARGS...: the evaluation of ARGS into DIR, FRONTIER_EVAL_N episodes (default K;
# not common.sh's EVAL_EPISODES, which other experiments use), once (once_locked).
eval_once() {
    local dir=$1
    shift
    once_locked "$dir" "${FRONTIER_EVAL_N:-$K}" eval "$@"
}

# eval_run RUN: the protocol's two evaluations of the finished run RUN (relative to S; none
# when empty).
eval_run() {
    local run=$1
    [ -n "$run" ] || return 0
    eval_once "$S/eval/$(basename "$run")/sampled" --checkpoint "$S/$run" || true
    eval_once "$S/eval/$(basename "$run")/deterministic" --checkpoint "$S/$run" \
        --deterministic || true
}

stage_eval() {
    local run
    for run in $(done_runs); do
        eval_run "$run"
    done
}

# The eval stage again every 5 minutes while runs are left to train (pending or running) or
# done runs are left to evaluate.
stage_eval-follow() {
    local run left
    while :; do
        stage_eval
        left=$(awk -F, 'NR > 1 && ($3 == "pending" || $3 == "running")' "$S/sweep.csv" | wc -l)
        for run in $(done_runs); do
            has_episodes "$S/eval/$(basename "$run")/sampled" "$K" &&
                has_episodes "$S/eval/$(basename "$run")/deterministic" "$K" || left=$((left + 1))
        done
        [ "$left" -gt 0 ] || break
        sleep 300
    done
    say "eval-follow: every run is trained and evaluated"
}

stage_comparators() {
    CHECK_SEED=$SEED CHECK_EPISODES=$K \
        CHECK_POLICIES="zero random upstream wall-angle:20 wall-angle:30 wall-angle:40 wall-angle:60 wall scripted" \
        bash experiments/frontier_check.sh "$CONFIG" "$S/comparators"
}

# of_points RUN POINTS: whether the run directory RUN (named p<point, zero-padded>_...) is of
# one of POINTS (point indices separated by spaces or commas, e.g. "3" or "2,3").
of_points() {
    local points=" ${2//,/ } "
    points=$(sed -E 's/ 0+([0-9])/ \1/g' <<<"$points")
    [[ $(basename "$1") =~ ^p0*([0-9]+)_ ]] && [[ $points == *" ${BASH_REMATCH[1]} "* ]]
}

stage_neighbours() {
    local run change
    if [ -z "${FRONTIER_NEIGHBOURS:-}" ]; then
        say "neighbours: skipped; name the variant(s) in FRONTIER_NEIGHBOURS (point indices; the protocol's is the one report --frontier ranks best)"
        return
    fi
    for run in $(done_runs); do
        of_points "$run" "$FRONTIER_NEIGHBOURS" || continue
        for change in "${NEIGHBOURS[@]}"; do
            once_locked "$S/neighbours/$(basename "$run")/$change" "$K" rollout \
                --set "${NEIGHBOUR_SET[$change]}" --policy "$S/$run" || true
        done
    done
}

# Exploratory (module header): each done run's policy snapshots, sampled, KC episodes each.
stage_curve() {
    local run f FRONTIER_EVAL_N=$KC
    for run in $(done_runs); do
        [ -z "${FRONTIER_CURVE_POINTS:-}" ] || of_points "$run" "$FRONTIER_CURVE_POINTS" || continue
        for f in "$S/$run"/policies/update-*.safetensors; do
            [ -f "$f" ] || continue
            eval_once "$S/curve/$(basename "$run")/$(basename "$f" .safetensors)" \
                --checkpoint "$f" || true
        done
    done
}

stage_report() {
    fluxswarm report --frontier "$S" --out "$S/report" >/dev/null
    say "report: $S/report/frontier.md"
}

stage_results() {
    local R=${FRONTIER_RESULTS:-assets/results/frontier_learners} run d f
    mkdir -p "$R"
    local finished
    finished=$(done_runs)
    cp "$S/sweep.csv" "$R/sweep.csv"
    for run in $finished; do
        mkdir -p "$R/runs/$(basename "$run")"
        cp "$S/$run/config.toml" "$S/$run/episodes.csv" "$R/runs/$(basename "$run")/"
        [ ! -f "$S/$run/policy.safetensors" ] ||
            cp "$S/$run/policy.safetensors" "$R/runs/$(basename "$run")/"
        # The snapshots of the curve's runs, so that a fresh checkout can evaluate them again.
        [ -n "${FRONTIER_CURVE_POINTS:-}" ] && of_points "$run" "$FRONTIER_CURVE_POINTS" || continue
        for f in "$S/$run"/policies/update-*.safetensors; do
            [ -f "$f" ] || continue
            mkdir -p "$R/snapshots/$(basename "$run")"
            cp "$f" "$R/snapshots/$(basename "$run")/"
        done
    done
    for d in "$S"/eval/*/* "$S"/neighbours/*/* "$S"/comparators/*; do
        [ -d "$d" ] && copy_complete "$d" "$R/${d#"$S"/}" "$K"
    done
    for d in "$S"/curve/*/*; do
        [ -d "$d" ] && copy_complete "$d" "$R/${d#"$S"/}" "$KC"
    done
    fluxswarm report --frontier "$R" --out "$R/report" >/dev/null
    say "results: $R (report: $R/report/frontier.md)"
}

stage_restore() {
    local R=${FRONTIER_RESULTS:-assets/results/frontier_learners} dir commit backend threads host d n=0
    [ -s "$R/sweep.csv" ] || { say "restore: $R/sweep.csv is missing; nothing to restore"; return 1; }
    [ -s "$S/sweep.toml" ] || fluxswarm sweep "$SPEC" --out "$S" --slurm >/dev/null
    fluxswarm sweep --status --out "$S" >/dev/null
    # The provenance columns are the last four; the quoted overrides come before them.
    while IFS='|' read -r dir commit backend threads host; do
        if ! awk -F, -v d="$dir" 'NR > 1 && $4 == d { f = 1 } END { exit !f }' "$S/sweep.csv"; then
            say "restore: $dir is not a run of $S's sweep; skipped"
            continue
        fi
        [ ! -e "$S/$dir/sweep-task.toml" ] || continue
        mkdir -p "$S/$dir"
        cp "$R/runs/$(basename "$dir")"/* "$S/$dir/"
        printf 'status = "done"\nhost = "%s"\nthreads = %s\nbackend = "%s"\ncommit = "%s"\n' \
            "$host" "${threads:-0}" "$backend" "$commit" >"$S/$dir/sweep-task.toml"
        n=$((n + 1))
    done < <(awk -F, 'NR > 1 && $3 == "done" { print $4 "|" $(NF-3) "|" $(NF-2) "|" $(NF-1) "|" $NF }' "$R/sweep.csv")
    for d in "$R"/eval/*/* "$R"/neighbours/*/* "$R"/comparators/*; do
        [ -e "$S/${d#"$R"/}" ] || copy_complete "$d" "$S/${d#"$R"/}" "$K"
    done
    for d in "$R"/curve/*/*; do
        [ -e "$S/${d#"$R"/}" ] || copy_complete "$d" "$S/${d#"$R"/}" "$KC"
    done
    # Kept snapshots go back into their run's policies/, where the curve stage reads them.
    for f in "$R"/snapshots/*/update-*.safetensors; do
        [ -f "$f" ] || continue
        dir=$S/runs/$(basename "$(dirname "$f")")
        [ -d "$dir" ] || { say "restore: $dir is not a run of $S; its snapshots are skipped"; continue; }
        mkdir -p "$dir/policies"
        [ -e "$dir/policies/$(basename "$f")" ] || cp "$f" "$dir/policies/"
    done
    fluxswarm sweep --status --out "$S"
    say "restore: $n run(s) restored from $R"
}

for stage in "${stages[@]}"; do
    case $stage in
        train | eval | eval-follow | comparators | neighbours | curve | report | results | restore) "stage_$stage" ;;
        *)
            echo "unknown stage '$stage' (train, eval, eval-follow, comparators, neighbours, curve, report, results, restore)" >&2
            exit 2
            ;;
    esac
done
