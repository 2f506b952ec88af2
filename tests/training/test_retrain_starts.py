"""Issue 36's training scripts start (and distil) from the policies their steps started from,
not from today's shipped files, which hold later steps (`experiments/routes/retrain/
earlier_policies.sh` writes the earlier ones from git into runs/earlier/)."""

from __future__ import annotations

import hashlib
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RETRAIN = ROOT / "experiments/routes/retrain"
SCRIPT = RETRAIN / "earlier_policies.sh"
SCRIPTS = [RETRAIN / "run.sh", RETRAIN / "camera_fullpace/run.sh",
           RETRAIN / "obstacle_fine/run.sh", RETRAIN / "obstacle_fine/why_slow/run.sh",
           RETRAIN / "camera_step10/run.sh", RETRAIN / "camera_step11/run.sh",
           RETRAIN / "step8/run.sh", RETRAIN / "step9/run.sh",
           RETRAIN / "step9_obstacle/run.sh", RETRAIN / "step10_obstacle/run.sh"]
COMMITS = {"d7ebd43", "322d217", "5b7da20", "64c7842", "259c59e", "444e677", "688936b"}
# The starts of step 8: today's shipped files unless step 8 ships (step8/README.md).
LATEST = {"ppo_generalist_steps1-6.pt", "obstacle_generalist_steps1-7.pt"}


def train_commands(path: Path) -> list[str]:
    """Each `h2h-racing train` command of a script, its continuation lines joined."""
    text = path.read_text().replace("\\\n", " ")
    return [line for line in text.splitlines() if "h2h-racing train" in line]


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: str(p.relative_to(RETRAIN)))
def test_scripts_start_from_earlier_policies(path):
    commands = train_commands(path)
    assert commands, f"{path}: no train command found"
    text = path.read_text()
    assert "earlier_policies.sh" in text  # the files exist before the first run
    for command in commands:
        init = re.search(r"--init (\S+)", command).group(1)
        # A shipped file (policies/trained/*/policy.pt) or name holds a later step now.
        assert not init.startswith("policies/trained/"), command
        assert init.startswith(("runs/earlier/", "${start[", "$init", "runs/camera_newteacher")), \
            command


def test_camera_steps_pin_their_teacher():
    # The camera configs name the teacher `ppo_generalist`, today steps 1-6; camera_pace/ was
    # taught by steps 1-2, camera_fullpace/ by steps 3-4 (seed 0).
    run = (RETRAIN / "run.sh").read_text()
    assert '[camera]="--teacher runs/earlier/ppo_generalist_steps1-2.pt"' in run
    (fullpace,) = train_commands(RETRAIN / "camera_fullpace/run.sh")
    assert "--teacher runs/earlier/ppo_generalist_steps1-4.pt" in fullpace


def have_history() -> bool:
    return all(subprocess.run(["git", "cat-file", "-e", f"{c}^{{commit}}"], cwd=ROOT,
                              capture_output=True).returncode == 0 for c in COMMITS)


@pytest.mark.skipif(not have_history(), reason="needs the repository's git history")
def test_earlier_policies_written_and_checked(tmp_path):
    from h2h_racing.policies.trained import load_policy_payload

    env = {"EARLIER_DIR": str(tmp_path), "PATH": "/usr/bin:/bin"}
    done = subprocess.run(["bash", str(SCRIPT)], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    files = sorted(p.name for p in tmp_path.iterdir())
    assert files == ["camera_generalist_steps1-7.pt", "camera_generalist_steps1-9.pt",
                     "obstacle_generalist_steps1-6.pt", "obstacle_generalist_steps1-7.pt",
                     "ppo_generalist_steps1-2.pt", "ppo_generalist_steps1-4.pt",
                     "ppo_generalist_steps1-6.pt"]
    observations = {name: load_policy_payload(tmp_path / name)["observations"] for name in files}
    assert observations["camera_generalist_steps1-7.pt"] == "camera_only"
    assert observations["camera_generalist_steps1-9.pt"] == "camera_only"
    assert observations["ppo_generalist_steps1-2.pt"] == "state"
    assert observations["ppo_generalist_steps1-6.pt"] == "state"
    # None but step 8's starts is today's shipped file: each is an earlier step.
    digest = {name: hashlib.sha256((tmp_path / name).read_bytes()).hexdigest() for name in files
              if name not in LATEST}
    for policy in ("ppo_generalist", "camera_generalist", "obstacle_generalist"):
        shipped = hashlib.sha256((ROOT / f"policies/trained/{policy}/policy.pt").read_bytes())
        assert shipped.hexdigest() not in digest.values(), policy

    # A file that is not the one it names is refused, by name, and left for the user to delete.
    bad = tmp_path / "ppo_generalist_steps1-2.pt"
    bad.write_bytes(b"not a policy")
    done = subprocess.run(["bash", str(SCRIPT)], env=env, capture_output=True, text=True)
    assert done.returncode == 1
    assert str(bad) in done.stderr and "expected c19dce2f" in done.stderr
    assert "delete it" in done.stderr
    assert bad.read_bytes() == b"not a policy"
