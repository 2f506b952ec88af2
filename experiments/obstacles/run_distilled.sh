#!/usr/bin/env bash
# obstacle_generalist candidate (issue 22): seeds 0, 1, 2 of CONFIG (distilled.toml by
# default) one after the other (MINUTES of training each, 8 by default), each followed by its figures on the 7 shipped
# tracks and the route files (evaluate_races.py: object-avoidance and head-to-bot races, seeds
# 1-3, and the time-trial lap against ppo_generalist), run beside the next seed's training, so
# that a cut-short series still has its first seeds.
#   experiments/obstacles/run_distilled.sh
# Writes runs/obstacles/: init_generalist.pt (prepare_init.py), distilled-seedN/ (the run,
# policy.pt), distilled-seedN.log, distilled-seedN-figures.{txt,json}, and
# distilled-summary.txt (every seed's totals).
set -u
cd "$(dirname "$0")/../.."
. /work/main/.venv/bin/activate
export GIT_PYTHON_REFRESH=quiet  # rsl-rl imports GitPython
MINUTES="${MINUTES:-8}"
# ITERATIONS fixes the run's length instead (MINUTES then only caps it).
ITERATIONS="${ITERATIONS:-100000}"
CONFIG="${CONFIG:-experiments/obstacles/distilled.toml}"
SEEDS="${SEEDS:-0 1 2}"
# Extra flags for a quick check of the script, e.g. TRAIN_ARGS="--envs 16"
# EVAL_ARGS="--tracks oval --routes none" MINUTES=0.1 SEEDS=0.
TRAIN_ARGS="${TRAIN_ARGS:-}"
EVAL_ARGS="${EVAL_ARGS:-}"
OUT="${OUT:-runs/obstacles}"
mkdir -p "$OUT"
python experiments/obstacles/prepare_init.py "$OUT/init_generalist.pt" || exit 1
for s in $SEEDS; do
  run="$OUT/distilled-seed$s"
  echo "$(date -u +%H:%M:%S) training seed $s -> $run"
  # --minutes decides the length unless ITERATIONS is given.
  h2h-racing train --config "$CONFIG" \
    --init "$OUT/init_generalist.pt" --minutes "$MINUTES" --iterations "$ITERATIONS" --seed "$s" \
    --no-onnx --no-progress --out "$run" $TRAIN_ARGS > "$run.log" 2>&1 \
    || { echo "seed $s failed: $run.log"; continue; }
  echo "$(date -u +%H:%M:%S) evaluating seed $s (in the background)"
  # On the second core while the next seed trains (training uses one thread).
  ( python experiments/obstacles/evaluate_races.py "$run/policy.pt" --json "$run-figures.json" \
      $EVAL_ARGS > "$run-figures.txt" 2>&1 || echo "seed $s evaluation failed: $run-figures.txt"
    echo "$(date -u +%H:%M:%S) seed $s evaluated" ) &
done
wait
for s in $SEEDS; do
  echo "== seed $s"
  grep -h "^total" "$OUT/distilled-seed$s-figures.txt" 2>/dev/null
done > "$OUT/distilled-summary.txt"
cat "$OUT/distilled-summary.txt"
echo "$(date -u +%H:%M:%S) done"
