"""``policies.torch_archive``: a ``torch.save`` file read without torch gives torch's tensors
exactly (as numpy arrays), runs nothing of the file, refuses what torch would refuse in one
line, and leaves to torch what only torch reads."""

from __future__ import annotations

import collections
import io
import pathlib
import pickle
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from h2h_racing.policies.torch_archive import DeferToTorch, load_arrays, read_archive
from h2h_racing.policies.trained import shipped_policies
from h2h_racing.policies.weights import WeightsFileError

torch = pytest.importorskip("torch")

EXPECTED = "a test file"


def assert_same(got: Any, want: Any, where: str = "") -> None:
    """``got`` is ``want`` with each tensor a numpy array of its dtype, shape and bytes."""
    if isinstance(want, torch.Tensor):
        assert isinstance(got, np.ndarray), where
        want = want.contiguous().numpy()
        assert got.dtype == want.dtype and got.shape == want.shape, where
        assert got.tobytes() == want.tobytes(), where
        assert got.flags.c_contiguous and got.flags.writeable, where
        return
    assert type(got) is type(want), (where, type(got), type(want))
    if isinstance(want, dict):
        assert list(got) == list(want), where
        for key in want:
            assert_same(got[key], want[key], f"{where}/{key}")
    elif isinstance(want, (list, tuple)):
        assert len(got) == len(want), where
        for i, (a, b) in enumerate(zip(got, want)):
            assert_same(a, b, f"{where}[{i}]")
    else:
        assert got == want, where


@pytest.mark.parametrize("name", sorted(shipped_policies()))
def test_every_shipped_policy_reads_as_torch_loads_it(name: str) -> None:
    path = shipped_policies()[name]
    assert_same(read_archive(path, EXPECTED), torch.load(path, weights_only=True))


def test_views_shared_storages_dtypes_and_state_dicts(tmp_path: Path) -> None:
    """Views (offsets, strides, a transpose), two tensors of one storage, every dtype numpy
    holds, 0-d and empty tensors, a module's state dict (an OrderedDict with _metadata)."""
    base = torch.arange(24, dtype=torch.float32).reshape(4, 6)
    saved = {
        "view": base[1:, 2:5], "transposed": base.t(), "same_storage": base[0],
        "scalar": torch.tensor(7, dtype=torch.int64), "empty": torch.zeros(0, 3),
        "dtypes": [torch.tensor([1.5, 2.0, 0.0], dtype=d) for d in
                   (torch.float64, torch.float16, torch.int32, torch.int16, torch.int8,
                    torch.uint8, torch.bool)],
        "module": torch.nn.Linear(3, 2).state_dict(),
        "plain": {"a": (1, 2.5, None, True, "x"), "b": [[], {}], "c": 2**70},
    }
    path = tmp_path / "views.pt"
    torch.save(saved, path)
    got = read_archive(path, EXPECTED)
    assert_same(got, torch.load(path, weights_only=True))
    assert type(got["module"]) is collections.OrderedDict
    assert got["module"]._metadata == torch.load(path, weights_only=True)["module"]._metadata


def _archive(tmp_path: Path, data_pkl: bytes, records: dict[str, bytes] | None = None,
             name: str = "crafted.pt") -> Path:
    """A zip laid out as torch.save lays it out, with the given pickle and records."""
    records = {"byteorder": b"little", **(records or {})}
    path = tmp_path / name
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("crafted/data.pkl", data_pkl)
        for record, data in records.items():
            archive.writestr(f"crafted/{record}", data)
    return path


def _records(tmp_path: Path, saved: Any) -> dict[str, bytes]:
    """The records of ``torch.save(saved)``'s archive, by name below its folder."""
    path = tmp_path / "saved.pt"
    torch.save(saved, path)
    with zipfile.ZipFile(path) as archive:
        return {info.filename.split("/", 1)[1]: archive.read(info)
                for info in archive.infolist()}


class _Touch:
    """Unpickles as ``Path(marker).touch()``, standing in for ``os.system``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, ...]:
        return (pathlib.Path.touch, (pathlib.Path(self.marker),))


def _one_line_refusal(path: Path, what: str) -> None:
    with pytest.raises(WeightsFileError) as info:
        read_archive(path, EXPECTED)
    text = str(info.value)
    assert "\n" not in text and str(path) in text and what in text and EXPECTED in text, text
    assert "weights_only=False" not in text


def test_code_in_the_pickle_is_refused_and_never_runs(tmp_path: Path) -> None:
    marker = tmp_path / "RAN"
    for protocol in (2, 4):
        path = _archive(tmp_path, pickle.dumps({"w": _Touch(marker)}, protocol=protocol))
        _one_line_refusal(path, "refused")
        assert not marker.exists()
    # The same as torch.save writes it: torch refuses it too (weights only).
    path = tmp_path / "evil.pt"
    torch.save({"w": _Touch(marker)}, path)
    _one_line_refusal(path, "refused: the pickle names the global builtins.getattr")
    with pytest.raises(WeightsFileError, match="refused"):
        load_arrays(path, EXPECTED)
    assert not marker.exists()
    os_system = b"\x80\x02cos\nsystem\nq\x00X\x04\x00\x00\x00trueq\x01\x85q\x02Rq\x03."
    _one_line_refusal(_archive(tmp_path, os_system), "the global os.system")


def test_opcodes_that_build_objects_are_refused(tmp_path: Path) -> None:
    # NEWOBJ of OrderedDict (allowed as a global, not as a class to instantiate that way);
    # REDUCE of a storage type; BUILD of a list; an OrderedDict built from arguments.
    newobj = b"\x80\x02ccollections\nOrderedDict\n)\x81."
    storage = b"\x80\x02ctorch\nFloatStorage\n)R."
    build = b"\x80\x02]}X\x01\x00\x00\x00aK\x01sb."
    from_args = b"\x80\x02ccollections\nOrderedDict\n]\x85R."
    for data, what in ((newobj, "opcode NEWOBJ"), (storage, "a call of"),
                       (build, "a BUILD of list"), (from_args, "built from arguments")):
        _one_line_refusal(_archive(tmp_path, data), what)


def test_truncated_and_corrupt_archives(tmp_path: Path) -> None:
    data = shipped_policies()["ppo_generalist"].read_bytes()
    for size in (100, len(data) // 2, len(data) - 1):
        cut = tmp_path / f"cut_{size}.pt"
        cut.write_bytes(data[:size])
        _one_line_refusal(cut, "truncated, corrupt")
    empty = tmp_path / "empty.pt"
    empty.write_bytes(b"")
    _one_line_refusal(empty, "empty")
    # A storage record shorter than its tensors, and one missing.
    records = _records(tmp_path, {"w": torch.ones(64)})
    records["data/0"] = records["data/0"][:100]
    pkl = records.pop("data.pkl")
    _one_line_refusal(_archive(tmp_path, pkl, records, "short.pt"), "holds 100 bytes")
    del records["data/0"]
    _one_line_refusal(_archive(tmp_path, pkl, records, "missing.pt"), "is missing")
    # A view reaching past its storage.
    bad = pkl.replace(b"K@\x85", b"K\x41\x85")  # size (64,) -> (65,)
    assert bad != pkl
    records["data/0"] = torch.ones(64).numpy().tobytes()
    _one_line_refusal(_archive(tmp_path, bad, records, "past.pt"), "reaching element 64")


def test_what_only_torch_reads_goes_to_torch(tmp_path: Path) -> None:
    """Not a zip (the legacy format), a dtype numpy lacks, a Parameter, a compressed record:
    ``DeferToTorch``, and ``load_arrays`` returns torch's own objects."""
    cases = {}
    legacy = tmp_path / "legacy.pt"
    torch.save({"w": torch.ones(2)}, legacy, _use_new_zipfile_serialization=False)
    cases[legacy] = "not a zip archive"
    bf16 = tmp_path / "bf16.pt"
    torch.save({"w": torch.ones(2, dtype=torch.bfloat16)}, bf16)
    cases[bf16] = "global torch.BFloat16Storage"
    parameter = tmp_path / "parameter.pt"
    torch.save({"w": torch.nn.Parameter(torch.ones(2))}, parameter)
    cases[parameter] = "global torch._utils._rebuild_parameter"
    compressed = tmp_path / "compressed.pt"
    buffer = io.BytesIO()
    torch.save({"w": torch.ones(2)}, buffer)
    with zipfile.ZipFile(io.BytesIO(buffer.getvalue())) as source, \
            zipfile.ZipFile(compressed, "w", zipfile.ZIP_DEFLATED) as target:
        for info in source.infolist():
            target.writestr(info.filename, source.read(info))
    cases[compressed] = "compressed records"
    for path, why in cases.items():
        with pytest.raises(DeferToTorch, match=why):
            read_archive(path, EXPECTED)
        got = load_arrays(path, EXPECTED)
        want = torch.load(path, weights_only=True)
        assert isinstance(got["w"], torch.Tensor) and torch.equal(got["w"], want["w"])


def test_big_endian_archives_are_swapped(tmp_path: Path) -> None:
    values = np.array([1.5, -2.25, 3e-8], dtype=np.float32)
    records = _records(tmp_path, {"w": torch.from_numpy(values)})
    pkl = records.pop("data.pkl")
    records.update({"byteorder": b"big", "data/0": values.astype(">f4").tobytes()})
    path = _archive(tmp_path, pkl, records, "big.pt")
    got = read_archive(path, EXPECTED)["w"]
    assert got.dtype == np.float32 and np.array_equal(got, values)
    assert np.array_equal(torch.load(path, weights_only=True)["w"].numpy(), values)


def test_reading_a_policy_file_does_not_import_torch() -> None:
    code = ("import sys; from h2h_racing.policies.torch_archive import load_arrays; "
            f"load_arrays({str(shipped_policies()['ppo_generalist'])!r}, 'x'); "
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "False"
