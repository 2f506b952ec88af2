"""The installed package: the wheel carries the track catalogue; layers stay apart."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

from h2h_racing.track_io import list_tracks

REPO = Path(__file__).resolve().parents[2]


class TestWheel:
    """A wheel built from the repository contains the catalogue and the subpackages."""

    def test_wheel_contains_every_catalogue_track(self, tmp_path: Path) -> None:
        result = subprocess.run(
            [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
             "-w", str(tmp_path), str(REPO)], capture_output=True, text=True, timeout=300)
        assert result.returncode == 0, result.stderr
        wheel = next(tmp_path.glob("h2h_racing-*.whl"))
        names = set(zipfile.ZipFile(wheel).namelist())
        for track in list_tracks():
            assert f"h2h_racing/catalogue/{track}.json" in names
            assert f"h2h_racing/catalogue/{track}.png" in names
        assert "h2h_racing/policies/scripted.py" in names
        assert "h2h_racing/league/vec_env.py" in names
        for policy in (REPO / "policies" / "trained").glob("*/policy.pt"):
            name = policy.parent.name
            assert f"h2h_racing/policies/trained/{name}/policy.pt" in names
            assert f"h2h_racing/policies/trained/{name}/CARD.md" in names
        # The training config files shipped beside some cards (h2h-racing train --config).
        for config in (REPO / "policies" / "trained").glob("*/*.toml"):
            assert config.relative_to(REPO / "policies").as_posix() in {
                n.removeprefix("h2h_racing/policies/") for n in names}
        # Every subpackage of h2h_racing/ made it (the package list in pyproject is explicit).
        for init in (REPO / "h2h_racing").rglob("__init__.py"):
            module = init.relative_to(REPO).as_posix()
            assert module in names, f"{module} is missing from the wheel: list its package"
        for source in (REPO / "h2h_racing").rglob("*.py"):
            assert source.relative_to(REPO).as_posix() in names


class TestLayers:
    """Only physics.py imports pymunk, only env.py pettingzoo; the env never imports torch, rerun
    or matplotlib."""

    def test_only_physics_imports_pymunk(self) -> None:
        sources = sorted((REPO / "h2h_racing").rglob("*.py"))
        importers = [p.relative_to(REPO).as_posix() for p in sources
                     if "import pymunk" in p.read_text()]
        assert importers == ["h2h_racing/physics.py"]

    def test_only_env_imports_pettingzoo(self) -> None:
        sources = sorted((REPO / "h2h_racing").rglob("*.py"))
        importers = [p.relative_to(REPO).as_posix() for p in sources
                     if "from pettingzoo" in p.read_text() or "import pettingzoo" in p.read_text()]
        assert importers == ["h2h_racing/env.py"]

    def test_env_never_imports_torch_or_rerun(self) -> None:
        code = ("import sys, h2h_racing; h2h_racing.parallel_env(track='oval').reset(seed=0); "
                "print([m for m in ('torch', 'rerun', 'matplotlib') if m in sys.modules])")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True).stdout.strip()
        assert out == "[]"
