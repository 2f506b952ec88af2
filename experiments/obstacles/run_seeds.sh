#!/usr/bin/env bash
# Three seeds of object_avoidance.toml, one after the other, then their figures.
set -u
cd "$(dirname "$0")/../.."
for s in 0 1 2; do
  h2h-racing train --config experiments/obstacles/object_avoidance.toml --init ppo_generalist \
    --minutes 8 --seed "$s" --no-onnx --no-progress --out "runs/oa_s$s" > "runs/oa_s$s.log" 2>&1
done
python experiments/obstacles/evaluate_oa.py ppo_generalist runs/oa_s0/policy.pt \
  runs/oa_s1/policy.pt runs/oa_s2/policy.pt > runs/oa_figures.txt 2>&1
