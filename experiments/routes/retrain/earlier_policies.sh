#!/usr/bin/env bash
# The shipped policies as they were before issue 36's steps replaced them, written from git into
# runs/earlier/ and checked against their SHA-256. Issue 36's scripts start from (or distil from)
# these files: the shipped names (`ppo_generalist`, policies/trained/*/policy.pt) now hold the
# later steps, so starting from them would not reproduce a step.
#   ppo_generalist_steps1-2.pt       ppo_generalist's steps 1-2 (d7ebd43): the start of its step 3
#                                    (../run.sh ppo); camera_generalist's teacher in steps 1-7 and
#                                    in camera_pace/ (../run.sh camera)
#   ppo_generalist_steps1-4.pt       its steps 3-4, seed 0 (322d217, runs/routes_ppo_s0):
#                                    camera_generalist's teacher in steps 8-9 (camera_newteacher/,
#                                    camera_fullpace/)
#   camera_generalist_steps1-7.pt    (5b7da20) the start of camera_generalist's step 8
#   camera_generalist_steps1-9.pt    (259c59e) the start of its steps 10 and 11 (camera_step10/,
#                                    camera_step11/)
#   obstacle_generalist_steps1-6.pt  (64c7842) the start of obstacle/ and obstacle_fine/ (step 7)
#   ppo_generalist_steps1-6.pt       its steps 5-6, seed 1 (444e677, runs/routes_ppo6_s1): the
#                                    start of its step 8 (step8/run.sh ppo)
#   obstacle_generalist_steps1-7.pt  its step 7, seed 1 (688936b, runs/obstacle_fine_s1): the
#                                    start of its step 8 (step8/run.sh obstacle)
#   bash experiments/routes/retrain/earlier_policies.sh     # needs the repository's history
# (EARLIER_DIR=FOLDER writes them there instead: the tests' copy)
set -eu
cd "$(dirname "$0")/../../.."
dir=${EARLIER_DIR:-runs/earlier}
mkdir -p "$dir"
while read -r name commit path sha; do
  file=$dir/$name.pt
  if [ ! -f "$file" ]; then
    git show "$commit:$path" > "$file.tmp" 2>/dev/null || {
      rm -f "$file.tmp"
      echo "earlier_policies.sh: cannot read $path at commit $commit from git; this needs the" \
           "repository's history (in a shallow clone: git fetch --unshallow)" >&2
      exit 1
    }
    mv "$file.tmp" "$file"
  fi
  got=$(sha256sum "$file" | cut -d' ' -f1)
  if [ "$got" != "$sha" ]; then
    echo "earlier_policies.sh: $file has SHA-256 $got, expected $sha ($path at $commit);" \
         "delete it and run this again" >&2
    exit 1
  fi
done <<'EOF'
ppo_generalist_steps1-2 d7ebd43 policies/trained/ppo_generalist/policy.pt c19dce2f46571fb306c10583c58d30a1414968eebff6bcb43f93f34004b757a9
ppo_generalist_steps1-4 322d217 policies/trained/ppo_generalist/policy.pt 1c5b05f3d521ee5ba919f4c156ce912f99c9d965d343c44ef3c7f887fe8e41ba
camera_generalist_steps1-7 5b7da20 policies/trained/camera_generalist/policy.pt 8df515800adc91e1e580b848d18947d430822e16d7d01ddc36e135dabfb6d2f6
camera_generalist_steps1-9 259c59e policies/trained/camera_generalist/policy.pt e2921eb12dd4e329d11fc14d5a3df03e82cc00e7f8e54d24884d0f2c8d7c1694
obstacle_generalist_steps1-6 64c7842 policies/trained/obstacle_generalist/policy.pt 3e1151fbf0f5b17387d2328e80b60b3c825000a39dddf730a0705d80784e3f7f
ppo_generalist_steps1-6 444e677 policies/trained/ppo_generalist/policy.pt 33d397e621a678d7836aabbb707f2fd3d54f6e56a0900efe566946bb05a9ad04
obstacle_generalist_steps1-7 688936b policies/trained/obstacle_generalist/policy.pt 6859c1213fbaa913f87c47431f9883fea41836a6a15f14da0024d0046378a4cf
EOF
