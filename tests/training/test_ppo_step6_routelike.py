"""The route-like tracks of ppo_generalist's step 6 (`experiments/routes/retrain/ppo_step6/
routelike.py`): written with the project's track writer, each file reads back as the very track
route_like(k) draws."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_files_read_back_as_the_drawn_tracks(tmp_path):
    from h2h_racing.track.io import load_track

    routelike = load(ROOT / "experiments/routes/retrain/ppo_step6/routelike.py", "routelike")
    paths = routelike.write_tracks(tmp_path, 2)
    assert [p.name for p in paths] == ["routelike_00.json", "routelike_01.json"]
    for k, path in enumerate(paths):
        drawn, read = routelike.route_like(k), load_track(str(path))
        np.testing.assert_array_equal(read.centre, drawn.centre)
        np.testing.assert_array_equal(read.width_left, drawn.width_left)
        np.testing.assert_array_equal(read.width_right, drawn.width_right)
        np.testing.assert_allclose(read.left_border, drawn.left_border)
        assert read.length == drawn.length

