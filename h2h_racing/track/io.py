"""Track loaders and writers: the JSON catalogue, DeepRacer ``.npy`` route files and centre-line CSV files.

* Catalogue: ``tracks/<name>.json`` in the repository (``h2h_racing/catalogue/`` in an installed wheel),
  format ``"h2h-racing-track/1"`` (see :func:`save_track`).
* DeepRacer: ``(N, 6)`` float64 arrays ``[cx, cy, inner_x, inner_y, outer_x, outer_y]`` [m]
  (aws-deepracer-community/deepracer-simapp ``bundle/routes``); every row is kept as ``waypoints``.
  Route files were drawn by hand and some carry drawing slips that DeepRacer raced on regardless:
  the 2019-era re:Invent 2018 file (71 rows) steps 2 mm backwards between two consecutive rows,
  others repeat a row or nearly repeat it. For the simulation's geometry (``Track.centre`` and
  the borders) a row closer than ``ROUTE_TOLERANCE`` to the previous kept row is left out
  (:func:`route_geometry_rows`); ``Track.waypoints`` (``params["waypoints"]``) keeps every row
  exactly as in the file, so the waypoint indices a reward function sees are the file's row
  indices. A larger backtrack, or a route that really crosses itself, is still refused.
* Centre-line CSV: ``x_m, y_m, w_tr_right_m, w_tr_left_m`` (TUMFTM racetrack-database, f1tenth racetracks),
  ``#`` comment lines, first row not repeated.

Only numpy, json and pathlib are used here.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any

import numpy as np

from h2h_racing.common.json_files import read_json_file
from h2h_racing.track.shape import MAX_TRACK_VERTICES, Track

TRACK_FORMAT = "h2h-racing-track/1"
"""Value of the ``"format"`` key of a catalogue JSON file."""
_JSON_KEYS = ("format", "name", "description", "x", "y", "width_left", "width_right")
_SUFFIXES = (".json", ".npy", ".csv")
ROUTE_TOLERANCE = 0.01
"""Largest step [m] between consecutive route rows that counts as a drawing slip (a near-duplicate
row or a tiny step backwards) and is left out of the geometry; DeepRacer's rows are ~5-30 cm apart."""
MAX_TRACK_FILE_BYTES = 32 * 2**20
"""Largest track file read [bytes]: a JSON file of :data:`h2h_racing.track.shape.MAX_TRACK_VERTICES`
vertices written by :func:`save_track` is about 9 MB, a CSV about 6 MB, a route ``.npy`` 5 MB."""
RANDOM_PREFIX = "random:"
"""``load_track("random:<seed>")`` generates a track with
:func:`h2h_racing.track.generator.random_track`."""


def catalogue_dir() -> Path:
    """Return the folder of the bundled catalogue (``h2h_racing/catalogue`` if installed, else ``tracks/``)."""
    pkg = Path(__file__).resolve().parents[1]  # h2h_racing/
    installed = pkg / "catalogue"
    return installed if installed.is_dir() else pkg.parent / "tracks"


def catalogue() -> dict[str, Path]:
    """Return the catalogue tracks as ``{name: path}``, sorted by name (names are the file stems)."""
    folder = catalogue_dir()
    if not folder.is_dir():
        return {}
    return {p.stem: p for p in sorted(folder.glob("*.json"))}


def list_tracks() -> list[str]:
    """Return the sorted names of the catalogue tracks."""
    return list(catalogue())


def load_track(
    name_or_path: str | Path,
    *,
    scale: float | tuple[float, float] | None = None,
    reverse: bool = False,
) -> Track:
    """Load a track from the catalogue or from a file.

    Args:
        name_or_path: A catalogue name (see :func:`list_tracks`), ``"random:<seed>"`` for a
            procedurally generated track (:func:`h2h_racing.track.generator.random_track` with
            that integer seed), or a path ending in ``.json``, ``.npy`` or ``.csv``.
        scale: Optional scaling about the origin: a float scales lengths and widths alike; a pair
            ``(length_scale, width_scale)`` scales coordinates and widths separately (real circuits need
            this: Catalunya's 4.65 km, ~11 m wide lap becomes DeepRacer's 60 m, 0.9 m wide one with about
            ``(0.0129, 0.082)``). Explicit DeepRacer borders are then recomputed from the scaled widths.
        reverse: Drive the track the other way round (:meth:`Track.reversed`).

    Returns:
        The validated :class:`Track`.

    Raises:
        FileNotFoundError: If the path does not exist.
        ValueError: If the name is unknown, the suffix unsupported, or the file malformed or invalid.
    """
    text = str(name_or_path)
    cat = catalogue()
    if isinstance(name_or_path, str) and (text.startswith(RANDOM_PREFIX) or text in cat):
        # Named tracks are immutable and loaded once per process: their lookup grid and any
        # racing line computed for them are shared by every env and driver that uses them.
        track = _load_named(text, cat.get(text))
    else:
        path = Path(name_or_path)
        if path.suffix.lower() not in _SUFFIXES:
            names = ", ".join(cat) or "(none found in " + str(catalogue_dir()) + ")"
            raise ValueError(
                f"Unknown track {text!r}. Expected a catalogue name ({names}), 'random:<seed>', or a "
                f"path ending in {', '.join(_SUFFIXES)}."
            )
        if not path.is_file():
            raise FileNotFoundError(f"Track file not found: {path.resolve()}")
        size = path.stat().st_size
        if size > MAX_TRACK_FILE_BYTES:
            raise ValueError(
                f"{path}: the file is {size} bytes; a track file may be at most {MAX_TRACK_FILE_BYTES} bytes "
                "(h2h_racing.track.io.MAX_TRACK_FILE_BYTES, room for 100,000 vertices)."
            )
        readers = {".json": _read_json, ".npy": _read_npy, ".csv": _read_csv}
        track = readers[path.suffix.lower()](path)
    if scale is not None:
        track = _scaled(track, scale)
    return track.reversed() if reverse else track


def save_track(track: Track, path: str | Path) -> Path:
    """Write ``track`` as a catalogue JSON file (centre line and widths; explicit borders are not kept).

    Args:
        track: The track to write.
        path: Destination, should end in ``.json``.

    Returns:
        The path written.
    """
    path = Path(path)
    doc = {
        "format": TRACK_FORMAT,
        "name": track.name,
        "description": track.description,
        "x": track.centre[:, 0].tolist(),
        "y": track.centre[:, 1].tolist(),
        "width_left": track.width_left.tolist(),
        "width_right": track.width_right.tolist(),
    }
    path.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return path


# ---------------------------------------------------------------------- readers


def _read_json(path: Path) -> Track:
    doc = read_json_file(path, "a track file", MAX_TRACK_FILE_BYTES)
    if not isinstance(doc, dict):
        raise ValueError(f"{path}: expected a JSON object with keys {list(_JSON_KEYS)}, got {type(doc).__name__}.")
    unknown = sorted(set(doc) - set(_JSON_KEYS))
    missing = [k for k in _JSON_KEYS if k not in doc]
    if unknown or missing:
        raise ValueError(
            f"{path}: expected exactly the keys {list(_JSON_KEYS)}; unknown keys {unknown}, missing keys {missing}."
        )
    if doc["format"] != TRACK_FORMAT:
        raise ValueError(f"{path}: expected format {TRACK_FORMAT!r}, got {doc['format']!r}.")
    arrays = {}
    for key in ("x", "y", "width_left", "width_right"):
        try:
            arrays[key] = np.array(doc[key], dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{path}: {key!r} must be a list of numbers ({exc}).") from exc
        if arrays[key].ndim != 1:
            raise ValueError(f"{path}: {key!r} must be a flat list of numbers, got shape {arrays[key].shape}.")
    if len(arrays["x"]) != len(arrays["y"]):
        raise ValueError(f"{path}: 'x' and 'y' must have the same length, got {len(arrays['x'])} and {len(arrays['y'])}.")
    return Track(
        np.stack([arrays["x"], arrays["y"]], axis=1),
        arrays["width_left"],
        arrays["width_right"],
        name=str(doc["name"]),
        description=str(doc["description"]),
        source=str(path),
    )


def _read_npy(path: Path) -> Track:
    _check_npy_header(path)
    try:
        rows = np.load(path, allow_pickle=False)
    except ValueError as exc:
        raise ValueError(f"{path}: not a plain numpy array file ({exc}).") from exc
    if rows.ndim != 2 or rows.shape[1] != 6 or not np.issubdtype(rows.dtype, np.floating):
        raise ValueError(
            f"{path}: expected a DeepRacer route array of shape (N, 6) float "
            f"[cx, cy, inner_x, inner_y, outer_x, outer_y], got shape {rows.shape} dtype {rows.dtype}."
        )
    rows = rows.astype(np.float64)
    if not np.all(np.isfinite(rows)):
        row = int(np.argwhere(~np.isfinite(rows))[0, 0])
        raise ValueError(f"{path}: row {row} has a non-finite value (NaN or inf): {rows[row]}. "
                         "All coordinates must be finite numbers.")
    # Geometry: the closing row is implied by the loop; slips closer than ROUTE_TOLERANCE to the
    # previous kept row are left out. The waypoints keep every row.
    geo = rows[route_geometry_rows(rows[:, 0:2])]
    centre, inner, outer = geo[:, 0:2], geo[:, 2:4], geo[:, 4:6]
    x, y = centre[:, 0], centre[:, 1]
    ccw = np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0
    # "inner" is the inside of the loop: on the left of travel when the loop runs counter-clockwise.
    left, right = (inner, outer) if ccw else (outer, inner)
    return Track(
        centre,
        np.hypot(*(left - centre).T),
        np.hypot(*(right - centre).T),
        name=path.stem,
        description=f"DeepRacer route {path.name}",
        source=str(path),
        left_border=left,
        right_border=right,
        waypoints=rows[:, 0:2],
    )


def _check_npy_header(path: Path) -> None:
    """Refuse a ``.npy`` file whose header claims more rows than a track may have, or more data
    than the file holds, before numpy allocates the array the header describes."""
    try:
        with path.open("rb") as f:
            version = np.lib.format.read_magic(f)
            readers = {(1, 0): np.lib.format.read_array_header_1_0,
                       (2, 0): np.lib.format.read_array_header_2_0}
            if version not in readers:
                raise ValueError(f"format version {version}; 1.0 and 2.0 are read")
            shape, _, dtype = readers[version](f)
            data_bytes = path.stat().st_size - f.tell()
    except (ValueError, OSError) as exc:
        raise ValueError(f"{path}: not a plain numpy array file ({exc}).") from None
    if len(shape) != 2 or shape[1] != 6 or dtype.kind != "f":
        raise ValueError(
            f"{path}: expected a DeepRacer route array of shape (N, 6) float "
            f"[cx, cy, inner_x, inner_y, outer_x, outer_y], got shape {shape} dtype {dtype}."
        )
    if shape[0] > MAX_TRACK_VERTICES:
        raise ValueError(f"{path}: the header claims {shape[0]} rows; a route may have at most "
                         f"{MAX_TRACK_VERTICES} (h2h_racing.track.shape.MAX_TRACK_VERTICES).")
    if shape[0] * 6 * dtype.itemsize > data_bytes:
        raise ValueError(f"{path}: the header claims {shape[0]} rows of 6 {dtype} values "
                         f"({shape[0] * 6 * dtype.itemsize} bytes), but the file holds {data_bytes} "
                         "bytes of data: it is truncated or not a route file.")


def _read_csv(path: Path) -> Track:
    try:
        data = np.loadtxt(path, delimiter=",", comments="#", dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise ValueError(
            f"{path}: expected numeric CSV rows x_m,y_m,w_tr_right_m,w_tr_left_m ({exc})."
        ) from exc
    if data.shape[1] != 4:
        raise ValueError(
            f"{path}: expected 4 columns x_m,y_m,w_tr_right_m,w_tr_left_m, got shape {data.shape}."
        )
    if not np.all(np.isfinite(data)):
        row = int(np.argwhere(~np.isfinite(data))[0, 0])
        raise ValueError(f"{path}: data row {row} has a non-finite value (NaN or inf): {data[row]}. "
                         "All values must be finite numbers.")
    # A repeated first row closes the loop; near-duplicate rows are left out as in route files.
    data = data[route_geometry_rows(data[:, 0:2])]
    return Track(
        data[:, 0:2],
        data[:, 3],
        data[:, 2],
        name=path.stem,
        description=f"centre-line CSV {path.name}",
        source=str(path),
    )


def route_geometry_rows(centre: np.ndarray, tolerance: float = ROUTE_TOLERANCE) -> np.ndarray:
    """Return the indices of the rows of a closed route that define its geometry.

    Walks the rows in order and keeps a row only when its centre point is at least ``tolerance``
    from the last kept one; a final row within ``tolerance`` of the first (the closing row, a
    repeat of row 0) is left out too. This removes exact and near duplicates and tiny steps
    backwards (a row a few millimetres behind its predecessor), which would otherwise make the
    centre polyline fold back onto itself; the rows between two kept rows lie within
    ``tolerance`` of the first of them, so the geometry moves by less than that.

    >>> route_geometry_rows(np.array([[0, 0], [1, 0], [0.998, 0], [2, 0], [2, 1], [0, 1], [0, 0]]))
    array([0, 1, 3, 4, 5])

    Args:
        centre: Centre points in file order, shape (N, 2) [m].
        tolerance: Smallest step [m] between kept rows.

    Returns:
        Increasing row indices, shape (M,), starting with 0.
    """
    keep = [0]
    last = centre[0]
    for i in range(1, len(centre)):
        if np.hypot(*(centre[i] - last)) >= tolerance:
            keep.append(i)
            last = centre[i]
    while len(keep) > 1 and np.hypot(*(centre[keep[-1]] - centre[0])) < tolerance:
        keep.pop()
    return np.asarray(keep, dtype=np.intp)


def _scaled(track: Track, scale: Any) -> Track:
    """Return ``track`` scaled about the origin by ``scale`` (float, or ``(length_scale, width_scale)``)."""
    try:
        pair = np.broadcast_to(np.asarray(scale, dtype=np.float64), (2,))
    except ValueError as exc:
        raise ValueError(
            f"{track.source}: expected scale as a float or a pair (length_scale, width_scale), got {scale!r}."
        ) from exc
    ls, ws = float(pair[0]), float(pair[1])
    if not (ls > 0 and ws > 0 and np.isfinite(ls) and np.isfinite(ws)):
        raise ValueError(f"{track.source}: scale factors must be finite and > 0, got {scale!r}.")
    uniform = ls == ws
    return Track(
        track.centre * ls,
        track.width_left * ws,
        track.width_right * ws,
        name=track.name,
        description=track.description,
        source=track.source,
        # A uniform scale keeps explicit borders; separate factors change their shape, so recompute them.
        left_border=track.left_border * ls if uniform and track._explicit_borders else None,
        right_border=track.right_border * ls if uniform and track._explicit_borders else None,
        waypoints=track.waypoints * ls,
    )


@functools.lru_cache(maxsize=64)
def _load_named(text: str, path: Path | None) -> Track:
    """Load a catalogue track (``path``) or build ``random:<seed>`` (``path`` None)."""
    return _random(text) if path is None else _read_json(path)


def _random(text: str) -> Track:
    """Build the procedurally generated track named ``random:<seed>``."""
    from h2h_racing.track.generator import random_track

    seed_text = text[len(RANDOM_PREFIX):]
    try:
        seed = int(seed_text)
    except ValueError:
        raise ValueError(f"Expected 'random:<integer seed>', got {text!r}.") from None
    spec = random_track(np.random.default_rng(seed))
    return Track(spec.centre, spec.width_left, spec.width_right, name=text,
                 description=spec.description, source=text)
