#!/usr/bin/env bash
# Issue 36's retraining: each generalist's "routes" step (its config's header; ppo_generalist's
# "routes_imitate" first) on 3 seeds, one after another, each measured on the 40 real routes (20 attempts or races per
# route) and on the shipped tracks right after its training. Logs and JSON beside this file.
# Each starts from the policy that the step started from, not from today's shipped one (which
# holds the later steps): earlier_policies.sh writes them from git into runs/earlier/. ppo:
# ppo_generalist's steps 1-2; obstacle: obstacle_generalist's steps 1-6; camera: camera_generalist's
# steps 1-7, with ppo_generalist's steps 1-2 as its teacher (the config names `ppo_generalist`,
# which now means steps 1-6: --teacher pins the file).
#   [SEEDS="0 1 2"] bash experiments/routes/retrain/run.sh [ppo|obstacle|camera ...]
set -u
cd "$(dirname "$0")/../../.."
bash experiments/routes/retrain/earlier_policies.sh || exit 1
export GIT_PYTHON_REFRESH=quiet
out=experiments/routes/retrain
routes=${ROUTES:-../shared/data/deepracer_tracks}
declare -A iterations=([ppo]=600 [obstacle]=400 [camera]=80)
declare -A start=([ppo]=runs/earlier/ppo_generalist_steps1-2.pt
                  [obstacle]=runs/earlier/obstacle_generalist_steps1-6.pt
                  [camera]=runs/earlier/camera_generalist_steps1-7.pt)
declare -A teacher=([ppo]="" [obstacle]="" [camera]="--teacher runs/earlier/ppo_generalist_steps1-2.pt")
# The configs of the steps that did not ship live here (obstacle/, camera_pace/).
declare -A config=([ppo]=ppo_generalist/routes [obstacle]=$out/obstacle/obstacle_routes.toml
                   [camera]=$out/camera_pace/camera_pace.toml)
for kind in ${*:-ppo obstacle camera}; do
  for seed in ${SEEDS:-0 1 2}; do
    name=${kind}_s$seed
    run=runs/routes_$name
    init=${start[$kind]}
    if [ $kind = ppo ]; then  # two steps: routes_imitate (DAgger from the planner), then PPO
      init=runs/routes_imitate_s$seed/policy.pt
      if [ ! -f $init ]; then
        h2h-racing train --config ppo_generalist/routes_imitate --init ${start[ppo]} \
          --seed $seed --iterations 150 --out runs/routes_imitate_s$seed --overwrite > $out/${name}_imitate.train.log 2>&1
      fi
    fi
    if [ ! -f $run/policy.pt ]; then
      h2h-racing train --config ${config[$kind]} --init $init ${teacher[$kind]} \
        --seed $seed --iterations ${iterations[$kind]} --out $run --overwrite > $out/$name.train.log 2>&1
    fi
    if [ $kind = obstacle ]; then
      for race_type in object_avoidance head_to_bot; do
        h2h-racing evaluate --policy $run/policy.pt --track $routes --race-type $race_type --races 20 \
          --json $out/${name}_$race_type.json > $out/${name}_$race_type.txt 2>&1
        h2h-racing evaluate --policy $run/policy.pt --track all --race-type $race_type --races 20 \
          > $out/${name}_${race_type}_shipped.txt 2>&1
      done
    else
      h2h-racing evaluate --policy $run/policy.pt --track $routes --episodes 20 \
        --json $out/$name.json > $out/$name.txt 2>&1
      h2h-racing evaluate --policy $run/policy.pt --track all --episodes 20 \
        > $out/${name}_shipped.txt 2>&1
    fi
    echo "$(date +%T) $name done" >> $out/progress.log
  done
done
