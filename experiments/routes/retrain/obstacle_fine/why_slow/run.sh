#!/usr/bin/env bash
# Why step 7's students lap slowly alone (obstacle_fine/README.md). Outputs beside this file.
# "The shipped policy" is obstacle_generalist's steps 1-6 as they were then (the shipped file
# now holds step 7): ../../earlier_policies.sh writes it from git.
#   bash experiments/routes/retrain/obstacle_fine/why_slow/run.sh
set -u
cd "$(dirname "$0")/../../../../.."
bash experiments/routes/retrain/earlier_policies.sh || exit 1
export GIT_PYTHON_REFRESH=quiet
here=experiments/routes/retrain/obstacle_fine/why_slow
tmp=$(mktemp -d)
# 1. Step 7 (seed 0) alone on the shipped tracks after 1, 51, 101, 201 and 400 iterations.
python $here/checkpoints.py runs/routes_obstacle_s0 $tmp/ckpt 0 50 100 200 399
for n in 0 50 100 200 399; do
  h2h-racing evaluate --policy $tmp/ckpt/model_$n.pt --track all --episodes 10 --jobs 1 \
    > $here/step7_s0_model_${n}_time_trial_shipped.txt 2>&1
done
# 2. racing_line and the students on the same tracks at their own and at DeepRacer-like waypoints.
python $here/resampled_tracks.py $tmp/resampled
for name in obstacle_generalist routes_obstacle_s0; do
  policy=runs/$name/policy.pt
  [ $name = obstacle_generalist ] && policy=runs/earlier/obstacle_generalist_steps1-6.pt
  h2h-racing evaluate --policy $policy --track $tmp/resampled --episodes 10 --jobs 1 \
    > $here/resampled_$name.txt 2>&1
done
# racing_line's planned line on them (its offsets and lap) and on 8 of DeepRacer's routes.
python $here/line_offsets.py $tmp/resampled > $here/line_offsets.txt
# 3. 50-iteration pilots from the shipped policy, one change each (seed 0), alone on the shipped tracks.
for v in v1_tt v2_narrowwide v3_step6 v4_nogap; do
  if [ -n "${PILOTS:-}" ]; then
    h2h-racing train --config $here/$v.toml --init runs/earlier/obstacle_generalist_steps1-6.pt \
      --seed 0 --iterations 50 --out $tmp/$v --no-onnx > /dev/null 2>&1
    h2h-racing evaluate --policy $tmp/$v/policy.pt --track all --episodes 10 --jobs 1 \
      > $here/${v}_time_trial_shipped.txt 2>&1
  fi
done
rm -rf $tmp
