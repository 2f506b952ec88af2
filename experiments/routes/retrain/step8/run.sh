#!/usr/bin/env bash
# Step 8 of ppo_generalist and obstacle_generalist (issue 36; README.md here: the plan, the seed
# rules and the ship rules, fixed before any training). Seeds 0, 1, 2 one after another on one
# core, each measured right after its training; logs and JSON beside this file, a progress.log
# line per step.
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/step8/run.sh ppo       # ppo8.toml, 300 it.
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/step8/run.sh obstacle  # obstacle8.toml, 400
# then: python experiments/routes/retrain/step8/choose_seed_{ppo,obstacle}.py
#
# ppo: from step 6 (runs/earlier/ppo_generalist_steps1-6.pt), measured as ../ppo_step6/run.sh
#   measures: the shipped tracks, the 30 route-like tracks (../ppo_step6/routelike.py), then the
#   40 routes, 20 one-lap attempts each.
# obstacle: from step 7 (runs/earlier/obstacle_generalist_steps1-7.pt), measured as
#   ../obstacle_fine/run.sh measures, the shipped tracks first (alone, 20 attempts; 20 races of
#   each race type), then the 40 routes in both race types (20 races), every one with --json.
#   Step 7's own pace alone on the shipped tracks (the seed rule's "within 2 %") is measured
#   once, first, the same way (obstacle7_time_trial_shipped.json).
# The starts are the earlier files, not policies/trained/*: those hold step 8 if it ships.
set -u
cd "$(dirname "$0")/../../../.."
mode=${1:-}
case $mode in
  ppo|obstacle) ;;
  *) echo "usage: run.sh ppo|obstacle (got '${mode}')" >&2; exit 2 ;;
esac
bash experiments/routes/retrain/earlier_policies.sh || exit 1
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1  # one core (torch_threads = 1)
out=experiments/routes/retrain/step8
routes=${ROUTES:-../shared/data/deepracer_tracks}
log=$out/progress.log

if [ "$mode" = obstacle ] && [ ! -f $out/obstacle7_time_trial_shipped.json ]; then
  h2h-racing evaluate --policy runs/earlier/obstacle_generalist_steps1-7.pt --track all \
    --episodes 20 --jobs 1 --json $out/obstacle7_time_trial_shipped.json \
    > $out/obstacle7_time_trial_shipped.txt 2>&1
  echo "$(date +%T) obstacle7 (step 7) alone on the shipped tracks done" >> $log
fi

for seed in ${SEEDS:-0 1 2}; do
  if [ "$mode" = ppo ]; then
    name=ppo8_s$seed
    run=runs/routes_ppo8_s$seed
  else
    name=obstacle8_s$seed
    run=runs/obstacle8_s$seed
  fi
  if [ ! -f $run/policy.pt ]; then
    echo "$(date +%T) $name training" >> $log
    if [ "$mode" = ppo ]; then
      h2h-racing train --config $out/ppo8.toml --init runs/earlier/ppo_generalist_steps1-6.pt \
        --seed $seed --iterations 300 --out $run --overwrite --no-progress \
        > $out/$name.train.log 2>&1
    else
      h2h-racing train --config $out/obstacle8.toml --init runs/earlier/obstacle_generalist_steps1-7.pt \
        --seed $seed --iterations 400 --out $run --overwrite --no-progress \
        > $out/$name.train.log 2>&1
    fi || { echo "$(date +%T) $name train failed" >> $log; continue; }
    echo "$(date +%T) $name trained" >> $log
  fi
  if [ "$mode" = ppo ]; then
    h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 --jobs 1 \
      --json $out/${name}_shipped.json > $out/${name}_shipped.txt 2>&1
    echo "$(date +%T) $name shipped tracks done" >> $log
    python experiments/routes/retrain/ppo_step6/routelike.py --policy $run/policy.pt \
      --json $out/${name}_routelike.json > $out/${name}_routelike.txt 2>&1
    echo "$(date +%T) $name route-like tracks done (rc $?)" >> $log
    h2h-racing evaluate --policy $run/policy.pt --track $routes --episodes 20 --jobs 1 \
      --json $out/$name.json > $out/$name.txt 2>&1
    echo "$(date +%T) $name routes done" >> $log
  else
    # The shipped tracks first: the seed to ship is chosen on them, before its routes are read.
    h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 --jobs 1 \
      --json $out/${name}_time_trial_shipped.json > $out/${name}_time_trial_shipped.txt 2>&1
    for race_type in object_avoidance head_to_bot; do
      h2h-racing evaluate --policy $run/policy.pt --track all --race-type $race_type \
        --races 20 --jobs 1 --json $out/${name}_${race_type}_shipped.json \
        > $out/${name}_${race_type}_shipped.txt 2>&1
    done
    echo "$(date +%T) $name shipped tracks done" >> $log
    for race_type in object_avoidance head_to_bot; do
      h2h-racing evaluate --policy $run/policy.pt --track $routes --race-type $race_type \
        --races 20 --jobs 1 --json $out/${name}_$race_type.json > $out/${name}_$race_type.txt 2>&1
      echo "$(date +%T) $name routes $race_type done" >> $log
    done
  fi
done
echo "$(date +%T) $mode: all seeds done" >> $log
