#!/usr/bin/env bash
# camera_fullpace.toml from each camera_newteacher seed, one seed after another, each measured
# on the 40 routes and the shipped tracks (20 attempts) right after its training.
# The teacher is ppo_generalist's steps 3-4 (seed 0), as it was when this ran: the config names
# `ppo_generalist`, which now holds steps 1-6, so --teacher pins the file (../earlier_policies.sh).
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/camera_fullpace/run.sh
set -u
cd "$(dirname "$0")/../../../.."
bash experiments/routes/retrain/earlier_policies.sh || exit 1
export GIT_PYTHON_REFRESH=quiet
out=experiments/routes/retrain/camera_fullpace
routes=${ROUTES:-../shared/data/deepracer_tracks}
for seed in ${SEEDS:-0 1 2}; do
  run=runs/camera_fullpace_s$seed
  if [ ! -f $run/policy.pt ]; then
    h2h-racing train --config $out/camera_fullpace.toml --init runs/camera_newteacher_s$seed/policy.pt \
      --teacher runs/earlier/ppo_generalist_steps1-4.pt --seed $seed --iterations 60 --out $run --overwrite > $out/camera_s$seed.train.log 2>&1
  fi
  h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 > $out/camera_s${seed}_shipped.txt 2>&1
  h2h-racing evaluate --policy $run/policy.pt --track $routes --episodes 20 \
    --json $out/camera_s$seed.json > $out/camera_s$seed.txt 2>&1
  echo "$(date +%T) camera_fullpace_s$seed done" >> $out/progress.log
done
