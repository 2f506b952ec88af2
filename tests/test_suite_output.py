"""The test command itself: piped or logged, collection shows it is alive (issue 37: 44 s of
silence before the first test)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_collection_names_each_test_folder_off_a_terminal() -> None:
    # One subprocess (about 7 s of CPU: the conftest imports h2h_racing, the modules theirs).
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-p", "no:cacheprovider",
         "tests/league/test_pfsp.py", "tests/training/test_config_file.py"],
        cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    lines = result.stdout.splitlines()
    collected = next(k for k, line in enumerate(lines) if line.startswith("collected "))
    shown = [line for line in lines[:collected] if line.startswith("collecting ")]
    assert sorted(shown) == ["collecting tests/league/ ...", "collecting tests/training/ ..."]
