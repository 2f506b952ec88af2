"""The installed package: the wheel carries the track catalogue; layers stay apart."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from h2h_racing.track.io import list_tracks

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="class")
def wheel_names(tmp_path_factory: pytest.TempPathFactory) -> set[str]:
    """The file names in a wheel built from the repository (built once for the class)."""
    out = tmp_path_factory.mktemp("wheel")
    result = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(out), str(REPO)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    wheel = next(out.glob("h2h_racing-*.whl"))
    return set(zipfile.ZipFile(wheel).namelist())


class TestWheel:
    """A wheel built from the repository contains the catalogue and the subpackages."""

    def test_wheel_contains_every_catalogue_track(self, wheel_names: set[str]) -> None:
        names = wheel_names
        for track in list_tracks():
            assert f"h2h_racing/catalogue/{track}.json" in names
            assert f"h2h_racing/catalogue/{track}.png" in names
        assert "h2h_racing/policies/scripted.py" in names
        assert "h2h_racing/training/vec_env.py" in names
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

    def test_wheel_ships_the_product_configs_and_no_experiments(
            self, wheel_names: set[str]) -> None:
        league_configs = {n for n in wheel_names
                          if n.startswith("h2h_racing/league/") and n.endswith(".toml")}
        assert league_configs == {"h2h_racing/league/recommended.toml",
                                  "h2h_racing/league/smoke.toml"}
        recorded = {p.name for p in (REPO / "experiments").rglob("*") if p.is_file()}
        assert recorded, "experiments/ holds the recorded runs"
        shipped = {n.rsplit("/", 1)[-1] for n in wheel_names}
        assert not any("experiments" in n for n in wheel_names)
        assert not recorded & shipped - {"README.md"}, recorded & shipped
        # Retired policies (their write-ups are in experiments/policies/) are not shipped.
        for retired in (REPO / "experiments" / "policies").glob("*.md"):
            assert not any(f"/trained/{retired.stem}/" in n for n in wheel_names), retired.stem

    def test_wheel_carries_licence_typing_marker_and_examples(
            self, wheel_names: set[str]) -> None:
        assert any(n.endswith(".dist-info/licenses/LICENSE") for n in wheel_names), sorted(
            n for n in wheel_names if ".dist-info/" in n)
        assert "h2h_racing/py.typed" in wheel_names
        for example in (REPO / "examples" / "deepracer").iterdir():
            assert f"h2h_racing/examples/deepracer/{example.name}" in wheel_names


class TestLayers:
    """Only physics.py imports pymunk, only env.py pettingzoo; the env never imports torch, rerun
    or matplotlib."""

    def test_only_physics_imports_pymunk(self) -> None:
        sources = sorted((REPO / "h2h_racing").rglob("*.py"))
        importers = [p.relative_to(REPO).as_posix() for p in sources
                     if "import pymunk" in p.read_text()]
        assert importers == ["h2h_racing/sim/physics.py"]

    def test_only_env_imports_pettingzoo(self) -> None:
        sources = sorted((REPO / "h2h_racing").rglob("*.py"))
        importers = [p.relative_to(REPO).as_posix() for p in sources
                     if "from pettingzoo" in p.read_text() or "import pettingzoo" in p.read_text()]
        assert importers == ["h2h_racing/envs/parallel.py"]

    def test_env_never_imports_torch_or_rerun(self) -> None:
        code = ("import sys, h2h_racing; h2h_racing.parallel_env(track='oval').reset(seed=0); "
                "print([m for m in ('torch', 'rerun', 'matplotlib') if m in sys.modules])")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True).stdout.strip()
        assert out == "[]"
