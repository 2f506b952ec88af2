#!/usr/bin/env bash
# obstacle_fine.toml (step 6 on the widened random tracks at 5 cm waypoints) from the shipped
# obstacle_generalist, one seed after another, each measured as ../run.sh obstacle measures:
# on the 40 routes (20 three-lap races a route, object avoidance and head to bot, --json), on
# the shipped tracks (the same), and alone on the shipped tracks (20 one-lap attempts against
# racing_line). Logs and JSON beside this file.
# "The shipped obstacle_generalist" is steps 1-6 as they were then (../earlier_policies.sh):
# the shipped file now holds step 7, this run's seed 1.
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/obstacle_fine/run.sh
set -u
cd "$(dirname "$0")/../../../.."
bash experiments/routes/retrain/earlier_policies.sh || exit 1
export GIT_PYTHON_REFRESH=quiet
out=experiments/routes/retrain/obstacle_fine
routes=${ROUTES:-../shared/data/deepracer_tracks}
for seed in ${SEEDS:-0 1 2}; do
  name=obstacle_s$seed
  run=runs/obstacle_fine_s$seed
  if [ ! -f $run/policy.pt ]; then
    h2h-racing train --config $out/obstacle_fine.toml --init runs/earlier/obstacle_generalist_steps1-6.pt \
      --seed $seed --iterations ${ITERATIONS:-400} --out $run --overwrite > $out/$name.train.log 2>&1
  fi
  # The shipped tracks first: the seed to ship is chosen on them, before its routes are read.
  h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 \
    > $out/${name}_time_trial_shipped.txt 2>&1
  for race_type in object_avoidance head_to_bot; do
    h2h-racing evaluate --policy $run/policy.pt --track all --race-type $race_type --races 20 \
      > $out/${name}_${race_type}_shipped.txt 2>&1
  done
  for race_type in object_avoidance head_to_bot; do
    h2h-racing evaluate --policy $run/policy.pt --track $routes --race-type $race_type --races 20 \
      --json $out/${name}_$race_type.json > $out/${name}_$race_type.txt 2>&1
  done
  echo "$(date +%T) $name done" >> $out/progress.log
done
