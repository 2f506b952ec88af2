#!/usr/bin/env bash
# Step 10 of obstacle_generalist (issue 36; README.md here: the plan, the seed rule and the ship
# rule, fixed before any training). obstacle10.toml (step 7's config, the teacher's box_edge 0
# beside the tight boxes only: box_edge_room 0.24) from step 7 (runs/earlier/
# obstacle_generalist_steps1-7.pt), 400 iterations, seeds 0, 1, 2 one after another on one
# core, each measured right after its training as ../step9_obstacle/run.sh measured step 9:
# the shipped tracks (alone, 20 attempts; 20 races of each race type), then (new) head to bot
# on the 20 narrow route-like tracks (routelike_narrow.py, 20 races), then the 40 routes in both
# race types (20 races), every one with --json. Logs and JSON beside this file, a progress.log
# line per step. The routes' figures are not read before choose_seed.py has chosen.
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/step10_obstacle/run.sh
# then: python experiments/routes/retrain/step10_obstacle/choose_seed.py   (no route read)
#       python experiments/routes/retrain/step10_obstacle/ship_check.py    (then the routes)
set -u
cd "$(dirname "$0")/../../../.."
bash experiments/routes/retrain/earlier_policies.sh || exit 1
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1  # one core (torch_threads = 1)
out=experiments/routes/retrain/step10_obstacle
routes=${ROUTES:-../shared/data/deepracer_tracks}
log=$out/progress.log

for seed in ${SEEDS:-0 1 2}; do
  name=obstacle10_s$seed
  run=runs/obstacle10_s$seed
  if [ ! -f $run/policy.pt ]; then
    echo "$(date +%T) $name training" >> $log
    h2h-racing train --config $out/obstacle10.toml --init runs/earlier/obstacle_generalist_steps1-7.pt \
      --seed $seed --iterations 400 --out $run --overwrite --no-progress \
      > $out/$name.train.log 2>&1 || { echo "$(date +%T) $name train failed" >> $log; continue; }
    echo "$(date +%T) $name trained" >> $log
  fi
  # The shipped and route-like tracks first: the seed is chosen on them, before its routes.
  h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 --jobs 1 \
    --json $out/${name}_time_trial_shipped.json > $out/${name}_time_trial_shipped.txt 2>&1
  for race_type in object_avoidance head_to_bot; do
    h2h-racing evaluate --policy $run/policy.pt --track all --race-type $race_type \
      --races 20 --jobs 1 --json $out/${name}_${race_type}_shipped.json \
      > $out/${name}_${race_type}_shipped.txt 2>&1
  done
  echo "$(date +%T) $name shipped tracks done" >> $log
  python $out/routelike_narrow.py --policy $run/policy.pt --json $out/${name}_routelike_narrow.json \
    > $out/${name}_routelike_narrow.txt 2>&1
  echo "$(date +%T) $name narrow route-like tracks done" >> $log
  for race_type in object_avoidance head_to_bot; do
    h2h-racing evaluate --policy $run/policy.pt --track $routes --race-type $race_type \
      --races 20 --jobs 1 --json $out/${name}_$race_type.json > $out/${name}_$race_type.txt 2>&1
    echo "$(date +%T) $name routes $race_type done" >> $log
  done
done
echo "$(date +%T) obstacle10: all seeds done" >> $log
