#!/usr/bin/env bash
# Issue 21's camera_generalist protocol: one-lap attempts from 20 start points on each shipped
# track and each DeepRacer route file beside the clone (../shared/data/deepracer_tracks/*.npy;
# never trained on), with the racing line and ppo_generalist on the same starts.
#   experiments/camera/evaluate_laps.sh POLICY [EVALUATE OPTIONS, e.g. --seed 1] > FIGURES.txt
set -u
cd "$(dirname "$0")/../.."
policy="$1"
shift
routes=(../shared/data/deepracer_tracks/*.npy)
for track in grand_loop hairpin_valley kidney oval speedway technical varying "${routes[@]}"; do
  [ -e "$track" ] || [[ "$track" != *.npy ]] || continue
  echo "== $track"
  h2h-racing evaluate --policy "$policy" --track "$track" --episodes 20 \
    --baseline ppo_generalist --no-progress "$@" || echo "evaluation failed on $track"
done
