#!/usr/bin/env bash
# ppo_generalist's step 5 (issue 36): step 4 (`runs/routes_ppo_sN`, config ppo_generalist/routes,
# 600 iterations) trained on for 300 more iterations, seeds 0, 1, 2 one after another, each
# measured on the 40 real routes (20 one-lap attempts a route) and on the shipped tracks right
# after its training. Logs and JSON beside this file, a progress.log line per step.
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/ppo_more/run.sh
#
# A continuation, not a restart: `--init` loads only the actor (its weights, observation
# normaliser and std), so the critic would start random, the optimiser fresh, and the random
# tracks would be drawn again from the seed's start (step 4's first 300 iterations' tracks).
# `--resume` from step 4's last checkpoint (model_599.pt: actor, critic, optimiser) goes on with
# all three, on the tracks step 4 would have drawn next; `--iterations` counts the whole run, so
# 900 = step 4's 600 + 300. The config is step 4's unchanged (ppo_generalist/routes). The PPO
# learning rate is rsl-rl's adaptive KL schedule (no iteration-based decay), and the std is the
# actor's learned parameter within max_std 0.3 either way.
set -u
cd "$(dirname "$0")/../../../.."
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1  # one core (torch_threads = 1)
out=experiments/routes/retrain/ppo_more
routes=${ROUTES:-../shared/data/deepracer_tracks}
for seed in ${SEEDS:-0 1 2}; do
  name=ppo5_s$seed
  step4=runs/routes_ppo_s$seed
  run=runs/routes_ppo5_s$seed
  if [ ! -f $run/policy.pt ]; then
    # Step 4's last checkpoint and curves, to resume from; a run stopped part-way (a folder with
    # checkpoints already: rsl-rl does not keep model_599.pt there) resumes from its latest.
    if ! ls $run/model_*.pt > /dev/null 2>&1; then
      mkdir -p $run && cp $step4/model_599.pt $step4/curves.csv $run/
    fi
    h2h-racing train --config ppo_generalist/routes --seed $seed --iterations 900 --resume \
      --out $run --no-progress > $out/$name.train.log 2>&1 || { echo "$(date +%T) $name train failed" >> $out/progress.log; continue; }
    echo "$(date +%T) $name trained" >> $out/progress.log
  fi
  h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 --jobs 1 \
    --json $out/${name}_shipped.json > $out/${name}_shipped.txt 2>&1
  echo "$(date +%T) $name shipped tracks done" >> $out/progress.log
  h2h-racing evaluate --policy $run/policy.pt --track $routes --episodes 20 --jobs 1 \
    --json $out/$name.json > $out/$name.txt 2>&1
  echo "$(date +%T) $name routes done" >> $out/progress.log
done
