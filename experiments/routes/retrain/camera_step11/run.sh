#!/usr/bin/env bash
# camera_generalist's step 11 (issue 36): the shipped camera_generalist (steps 1-9, SHA-256
# checked below) distilled on from today's ppo_generalist (steps 1-6, seed 1; the config names
# it) with step 8's config (camera_generalist/routes: the widened tracks, labels at 95 % of the
# teacher's speed), 60 iterations as step 10, seeds 0, 1, 2 one after another on one core, each
# measured right after its training: the shipped tracks (against ppo_generalist), the 30
# route-like tracks (../ppo_step6/routelike.py), then the 40 real routes (20 one-lap attempts
# each). The seed is chosen by choose_seed.py from the first two only. Logs and JSON beside
# this file.
#   [SEEDS="0 1 2"] [START=file] bash experiments/routes/retrain/camera_step11/run.sh
set -u
cd "$(dirname "$0")/../../../.."
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1  # one core
out=experiments/routes/retrain/camera_step11
routes=${ROUTES:-../shared/data/deepracer_tracks}
start=${START:-policies/trained/camera_generalist/policy.pt}
steps1to9=e2921eb12dd4e329d11fc14d5a3df03e82cc00e7f8e54d24884d0f2c8d7c1694
if [ "$(sha256sum < "$start" | cut -d' ' -f1)" != $steps1to9 ]; then
  echo "$start is not camera_generalist's steps 1-9 (SHA-256 $steps1to9), which step 11" \
    "starts from; write it with: git show 259c59e:policies/trained/camera_generalist/policy.pt" \
    "> runs/earlier/camera_generalist_steps1-9.pt, then START=that file bash $0" >&2
  exit 1
fi
for seed in ${SEEDS:-0 1 2}; do
  name=camera11_s$seed
  run=runs/camera_step11_s$seed
  if [ ! -f $run/policy.pt ]; then
    h2h-racing train --config camera_generalist/routes --init $start --seed $seed \
      --iterations 60 --out $run --overwrite --no-progress > $out/$name.train.log 2>&1 \
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
