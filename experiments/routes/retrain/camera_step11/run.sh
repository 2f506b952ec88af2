#!/usr/bin/env bash
# camera_generalist's step 11 (issue 36): camera_generalist's steps 1-9 (shipped until step 11;
# ../earlier_policies.sh writes it from git, checked by SHA-256) distilled on from today's
# ppo_generalist (steps 1-6, seed 1; the config names it) with step 8's config
# (camera_generalist/routes: the widened tracks, labels at 95 % of the teacher's speed), 60
# iterations as step 10, seeds 0, 1, 2 one after another on one core, each
# measured right after its training: the shipped tracks (against ppo_generalist), the 30
# route-like tracks (../ppo_step6/routelike.py), then the 40 real routes (20 one-lap attempts
# each). The seed is chosen by choose_seed.py from the first two only. Logs and JSON beside
# this file.
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/camera_step11/run.sh
set -u
cd "$(dirname "$0")/../../../.."
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1  # one core
out=experiments/routes/retrain/camera_step11
routes=${ROUTES:-../shared/data/deepracer_tracks}
# The shipped file holds step 11 now: start from steps 1-9 as they were.
bash experiments/routes/retrain/earlier_policies.sh || exit 1
for seed in ${SEEDS:-0 1 2}; do
  name=camera11_s$seed
  run=runs/camera_step11_s$seed
  if [ ! -f $run/policy.pt ]; then
    h2h-racing train --config camera_generalist/routes \
      --init runs/earlier/camera_generalist_steps1-9.pt --seed $seed --iterations 60 \
      --out $run --overwrite --no-progress > $out/$name.train.log 2>&1 \
      || { echo "$(date +%T) $name train failed" >> $out/progress.log; continue; }
    echo "$(date +%T) $name trained" >> $out/progress.log
  fi
  h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 --jobs 1 \
    --baseline ppo_generalist --json $out/${name}_shipped.json > $out/${name}_shipped.txt 2>&1
  python experiments/routes/retrain/ppo_step6/routelike.py --policy $run/policy.pt \
    --json $out/${name}_routelike.json > $out/${name}_routelike.txt 2>&1
  echo "$(date +%T) $name shipped and route-like tracks done" >> $out/progress.log
  h2h-racing evaluate --policy $run/policy.pt --track $routes --episodes 20 --jobs 1 \
    --baseline '' --json $out/$name.json > $out/$name.txt 2>&1
  echo "$(date +%T) $name routes done" >> $out/progress.log
done
