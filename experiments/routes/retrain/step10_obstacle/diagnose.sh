#!/usr/bin/env bash
# Step 10's diagnosis after the three seeds (README.md, "Why"): is the head-to-bot drift on
# narrow tracks the teacher's box_edge at all? (1) head to bot on the narrow route-like tracks
# for step 7's other two seeds (runs/obstacle_fine_s0, _s2: the same config and start as the
# shipped seed 1) and step 8's three seeds; (2) a control: step 7's own config, unchanged
# teacher, 400 more iterations from step 7 (seed 0, as obstacle10_s0 / obstacle9_s0), then the
# same check. Diagnosis only: the control is not a candidate (no seed rule, no routes read).
#   bash experiments/routes/retrain/step10_obstacle/diagnose.sh
set -u
cd "$(dirname "$0")/../../../.."
export GIT_PYTHON_REFRESH=quiet OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
out=experiments/routes/retrain/step10_obstacle
log=$out/diagnose.log
for p in obstacle_fine_s0 obstacle_fine_s2 obstacle8_s0 obstacle8_s1 obstacle8_s2; do
  python $out/routelike_narrow.py --policy runs/$p/policy.pt --json $out/diag_${p}_routelike_narrow.json \
    > $out/diag_${p}_routelike_narrow.txt 2>&1
  echo "$(date +%T) $p narrow done" >> $log
done
run=runs/obstacle10_control_s0
if [ ! -f $run/policy.pt ]; then
  echo "$(date +%T) control training" >> $log
  h2h-racing train --config obstacle_generalist/routes --init runs/earlier/obstacle_generalist_steps1-7.pt \
    --seed 0 --iterations 400 --out $run --overwrite --no-progress > $out/control_s0.train.log 2>&1 \
    || { echo "$(date +%T) control train failed" >> $log; exit 1; }
  echo "$(date +%T) control trained" >> $log
fi
python $out/routelike_narrow.py --policy $run/policy.pt --json $out/diag_control_s0_routelike_narrow.json \
  > $out/diag_control_s0_routelike_narrow.txt 2>&1
h2h-racing evaluate --policy $run/policy.pt --track all --race-type head_to_bot --races 20 --jobs 1 \
  --json $out/diag_control_s0_head_to_bot_shipped.json > $out/diag_control_s0_head_to_bot_shipped.txt 2>&1
echo "$(date +%T) control measured" >> $log
