#!/usr/bin/env bash
# Step 10's diagnosis, part 3 (README.md, "Why"): along control seed 0's 400 iterations (step
# 7's recipe unchanged, from step 7), when does Bowtie's object avoidance come and when do the
# narrow route-like tracks go? Its checkpoints (model_N.pt, as policy files by
# ../obstacle_fine/why_slow/checkpoints.py) alone on the 20 narrow tracks (20 attempts), in
# head to bot there (20 races), and in object avoidance on Bowtie_track (20 races).
#   bash experiments/routes/retrain/step10_obstacle/checkpoints.sh
set -u
cd "$(dirname "$0")/../../../.."
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
out=experiments/routes/retrain/step10_obstacle
routes=${ROUTES:-../shared/data/deepracer_tracks}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python experiments/routes/retrain/obstacle_fine/why_slow/checkpoints.py runs/obstacle10_control_s0 \
  $tmp/ckpt 50 100 200 300
mkdir -p $tmp/narrow
python -c "import sys; sys.path.insert(0, '$out'); from pathlib import Path; \
from routelike_narrow import write_tracks; write_tracks(Path('$tmp/narrow'))"
for n in 50 100 200 300; do
  p=$tmp/ckpt/model_$n.pt
  name=ckpt_control_s0_model_$n
  h2h-racing evaluate --policy $p --track $tmp/narrow --episodes 20 --jobs 1 --no-progress \
    --json $out/${name}_narrow_alone.json > $out/${name}_narrow_alone.txt 2>&1
  h2h-racing evaluate --policy $p --track $tmp/narrow --race-type head_to_bot --races 20 --jobs 1 \
    --no-progress --json $out/${name}_narrow_head_to_bot.json > $out/${name}_narrow_head_to_bot.txt 2>&1
  h2h-racing evaluate --policy $p --track $routes/Bowtie_track.npy --race-type object_avoidance \
    --races 20 --jobs 1 --no-progress > $out/${name}_bowtie_object_avoidance.txt 2>&1
  echo "$(date +%T) model_$n done" >> $out/checkpoints.log
done
