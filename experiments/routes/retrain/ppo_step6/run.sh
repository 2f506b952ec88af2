#!/usr/bin/env bash
# ppo_generalist's step 6 (issue 36): step 5 (`runs/routes_ppo5_sN`, config ppo_generalist/routes,
# 900 iterations) trained on for 300 more iterations, seeds 0, 1, 2 one after another, each
# measured right after its training on the shipped tracks, the 30 route-like procedural tracks
# (`routelike.py`) and the 40 real routes (20 one-lap attempts each). Logs and JSON beside this
# file, a progress.log line per step.
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/ppo_step6/run.sh
#
# A continuation as step 5 was (../ppo_more/run.sh): step 5's last checkpoint (model_899.pt:
# actor, critic, optimiser; seed 2's too, after its resume at 871) and curves are copied into
# `runs/routes_ppo6_sN` and the run resumes there with `--iterations 1200` (the whole run:
# 900 + 300), on the tracks step 5 would have drawn next. Same config, unchanged.
set -u
cd "$(dirname "$0")/../../../.."
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1  # one core (torch_threads = 1)
out=experiments/routes/retrain/ppo_step6
routes=${ROUTES:-../shared/data/deepracer_tracks}
for seed in ${SEEDS:-0 1 2}; do
  name=ppo6_s$seed
  step5=runs/routes_ppo5_s$seed
  run=runs/routes_ppo6_s$seed
  if [ ! -f $run/policy.pt ]; then
    # A run stopped part-way (checkpoints already there) resumes from its latest.
    if ! ls $run/model_*.pt > /dev/null 2>&1; then
      mkdir -p $run && cp $step5/model_899.pt $step5/curves.csv $run/
    fi
    h2h-racing train --config ppo_generalist/routes --seed $seed --iterations 1200 --resume \
      --out $run --no-progress >> $out/$name.train.log 2>&1 || { echo "$(date +%T) $name train failed" >> $out/progress.log; continue; }
    echo "$(date +%T) $name trained" >> $out/progress.log
  fi
  h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 --jobs 1 \
    --json $out/${name}_shipped.json > $out/${name}_shipped.txt 2>&1
  echo "$(date +%T) $name shipped tracks done" >> $out/progress.log
  python $out/routelike.py --policy $run/policy.pt --json $out/${name}_routelike.json \
    > $out/${name}_routelike.txt 2>&1
  echo "$(date +%T) $name route-like tracks done (rc $?)" >> $out/progress.log
  h2h-racing evaluate --policy $run/policy.pt --track $routes --episodes 20 --jobs 1 \
    --json $out/$name.json > $out/$name.txt 2>&1
  echo "$(date +%T) $name routes done" >> $out/progress.log
done
