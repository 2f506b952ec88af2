#!/usr/bin/env bash
# Step 9 of ppo_generalist (issue 36; README.md here: the plan, the seed rule and the ship rule,
# fixed before any training). ppo9.toml from step 6 (runs/earlier/ppo_generalist_steps1-6.pt),
# 300 iterations, seeds 0, 1, 2 one after another on one core, each measured right after its
# training as ../step8/run.sh ppo measures: the shipped tracks, the 30 route-like tracks
# (../ppo_step6/routelike.py), then the 40 routes, 20 one-lap attempts each. Logs and JSON beside
# this file, a progress.log line per step.
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/step9/run.sh
# then: python experiments/routes/retrain/step9/choose_seed.py > .../choose_seed.txt, and only
# then python experiments/routes/retrain/step9/ship_rule.py
set -u
cd "$(dirname "$0")/../../../.."
bash experiments/routes/retrain/earlier_policies.sh || exit 1
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1  # one core (torch_threads = 1)
out=experiments/routes/retrain/step9
routes=${ROUTES:-../shared/data/deepracer_tracks}
log=$out/progress.log
for seed in ${SEEDS:-0 1 2}; do
  name=ppo9_s$seed
  run=runs/routes_ppo9_s$seed
  if [ ! -f $run/policy.pt ]; then
    echo "$(date +%T) $name training" >> $log
    h2h-racing train --config $out/ppo9.toml --init runs/earlier/ppo_generalist_steps1-6.pt \
      --seed $seed --iterations 300 --out $run --overwrite --no-progress \
      > $out/$name.train.log 2>&1 || { echo "$(date +%T) $name train failed" >> $log; continue; }
    echo "$(date +%T) $name trained" >> $log
  fi
  h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 --jobs 1 \
    --json $out/${name}_shipped.json > $out/${name}_shipped.txt 2>&1
  echo "$(date +%T) $name shipped tracks done" >> $log
  python experiments/routes/retrain/ppo_step6/routelike.py --policy $run/policy.pt \
    --json $out/${name}_routelike.json > $out/${name}_routelike.txt 2>&1
  echo "$(date +%T) $name route-like tracks done (rc $?)" >> $log
  h2h-racing evaluate --policy $run/policy.pt --track $routes --episodes 20 --jobs 1 \
    --json $out/$name.json > $out/$name.txt 2>&1
  echo "$(date +%T) $name routes done" >> $log
done
echo "$(date +%T) all seeds done" >> $log
