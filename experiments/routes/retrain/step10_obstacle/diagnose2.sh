#!/usr/bin/env bash
# Step 10's diagnosis, part 2 (README.md, "Why"), after diagnose.sh found the control (step 7's
# own config and teacher, 400 more iterations from step 7, seed 0) as far off on the narrow
# route-like tracks as step 9's and step 10's seed 0: the control on the 40 routes (both race
# types: does the teacher's box_edge or the extra training give Bowtie its room?), then a
# second control seed (2) measured the same way. Diagnosis only: no control is a candidate.
#   bash experiments/routes/retrain/step10_obstacle/diagnose2.sh
set -u
cd "$(dirname "$0")/../../../.."
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
out=experiments/routes/retrain/step10_obstacle
routes=${ROUTES:-../shared/data/deepracer_tracks}
log=$out/diagnose.log
for seed in 0 2; do
  run=runs/obstacle10_control_s$seed
  name=diag_control_s$seed
  if [ ! -f $run/policy.pt ]; then
    echo "$(date +%T) control s$seed training" >> $log
    h2h-racing train --config obstacle_generalist/routes --init runs/earlier/obstacle_generalist_steps1-7.pt \
      --seed $seed --iterations 400 --out $run --overwrite --no-progress > $out/control_s$seed.train.log 2>&1 \
      || { echo "$(date +%T) control s$seed train failed" >> $log; exit 1; }
    echo "$(date +%T) control s$seed trained" >> $log
    python $out/routelike_narrow.py --policy $run/policy.pt --json $out/${name}_routelike_narrow.json \
      > $out/${name}_routelike_narrow.txt 2>&1
  fi
  for race_type in object_avoidance head_to_bot; do
    h2h-racing evaluate --policy $run/policy.pt --track $routes --race-type $race_type \
      --races 20 --jobs 1 --json $out/${name}_$race_type.json > $out/${name}_$race_type.txt 2>&1
  done
  echo "$(date +%T) control s$seed measured" >> $log
done
