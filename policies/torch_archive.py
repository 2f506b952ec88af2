"""Read a weights file that ``torch.save`` wrote, without torch: tensors come back as numpy
arrays.

A trained driver reads its policy file here (``load_arrays``), so that a command driving a
state-observation policy never imports torch (2-3 s of its start; ``trained_numpy`` then acts
in numpy). The file is the zip archive ``torch.save`` writes: ``<name>/data.pkl``, a pickle of
the saved object, and ``<name>/data/<key>``, the raw bytes of each tensor's storage. The pickle
is read by Python's reference unpickler (``pickle._Unpickler``) restricted to what a dict of
tensors and plain values needs:

- opcodes: the ones that build numbers, strings, lists, tuples, dicts and sets, the memo, and
  ``GLOBAL``/``REDUCE``/``BUILD``/``BINPERSID`` as checked below; nothing that makes an object
  of a named class (``INST``, ``OBJ``, ``NEWOBJ``), no extension registry, no out-of-band
  buffers;
- globals: ``collections.OrderedDict``, ``torch._utils._rebuild_tensor_v2`` (here: a numpy
  view of a storage, copied) and the storage types of numpy's dtypes (``torch.FloatStorage``
  and the like, only as arguments of a storage reference), and nothing is called but those;
- storage references: ``("storage", <storage type>, key, location, numel)``, read from
  ``data/<key>`` (which must hold at least ``numel`` elements), byte-swapped when the
  archive's ``byteorder`` is not this machine's.

So reading a file runs no code of it, as ``torch.load(weights_only=True)`` does not. What it
refuses is one of three things:

- not torch's zip archive at all (no ``PK`` signature: a legacy ``torch.save`` file or another
  kind of file), a global or a dtype of torch's that numpy has no twin for (``bfloat16``, a
  ``Parameter``, ``torch.Size``, ...), a compressed record, or tensor metadata: ``DeferToTorch``;
  ``load_arrays`` then reads the file with ``torch.load(weights_only=True)``
  (``policies.weights.load_weights``), which reads what it can and refuses the rest with its
  own clear error, and the driver acts with torch;
- anything else, a file torch would refuse too: a ``WeightsFileError`` in one line naming the
  file and what is wrong (a truncated or corrupt archive, a global outside torch's
  weights-only list such as ``os.system``, an opcode that builds objects, a storage shorter
  than its tensors), without importing torch.

``tests/policies/test_torch_archive.py`` checks that every shipped policy reads to torch's
tensors exactly.
"""

from __future__ import annotations

import _compat_pickle
import collections
import io
import pickle
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from h2h_racing.policies.weights import WeightsFileError

STORAGE_DTYPES = {"FloatStorage": np.float32, "DoubleStorage": np.float64,
                  "HalfStorage": np.float16, "LongStorage": np.int64, "IntStorage": np.int32,
                  "ShortStorage": np.int16, "CharStorage": np.int8, "ByteStorage": np.uint8,
                  "BoolStorage": np.bool_}
"""torch's storage types (``torch.<name>``) that numpy holds exactly, with their dtype."""
TORCH_READS = frozenset(("collections.Counter", "_codecs.encode", "builtins.bytearray",
                         "builtins.set", "builtins.complex"))
"""Globals outside ``torch`` that ``torch.load(weights_only=True)`` accepts and this reader
leaves to it (with every global of ``torch`` itself; see ``DeferToTorch``)."""
_OPCODES = frozenset((
    "PROTO", "FRAME", "STOP", "MARK", "POP", "POP_MARK", "DUP", "NONE", "NEWTRUE", "NEWFALSE",
    "INT", "BININT", "BININT1", "BININT2", "LONG", "LONG1", "LONG4", "FLOAT", "BINFLOAT",
    "STRING", "BINSTRING", "SHORT_BINSTRING", "UNICODE", "BINUNICODE", "SHORT_BINUNICODE",
    "BINUNICODE8", "BINBYTES", "SHORT_BINBYTES", "BINBYTES8", "EMPTY_TUPLE", "TUPLE",
    "TUPLE1", "TUPLE2", "TUPLE3", "EMPTY_LIST", "APPEND", "APPENDS", "LIST", "EMPTY_DICT",
    "DICT", "SETITEM", "SETITEMS", "EMPTY_SET", "ADDITEMS", "FROZENSET", "GET", "BINGET",
    "LONG_BINGET", "PUT", "BINPUT", "LONG_BINPUT", "MEMOIZE", "GLOBAL", "STACK_GLOBAL",
    "REDUCE", "BUILD", "BINPERSID"))
"""The pickle opcodes a dict of tensors and plain values needs (``GLOBAL``, ``REDUCE``,
``BUILD`` and ``BINPERSID`` checked further)."""


class DeferToTorch(Exception):
    """The file may be one that only torch reads (why: the message); ``load_arrays`` hands it
    to ``torch.load(weights_only=True)``."""


class _Refused(Exception):
    """What the pickle holds that no weights file holds (the message)."""


class _StorageType:
    """A storage type global (``torch.FloatStorage``): only a storage reference's argument."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.dtype = np.dtype(STORAGE_DTYPES[name])


def load_arrays(path: str | Path, expected: str) -> Any:
    """``policies.weights.load_weights(path, expected)``, with numpy arrays for the tensors
    where this reader can (``read_archive``), else torch's own (``DeferToTorch``)."""
    try:
        return read_archive(path, expected)
    except DeferToTorch:
        from h2h_racing.policies.weights import load_weights

        return load_weights(path, expected)


def read_archive(path: str | Path, expected: str) -> Any:
    """The object ``torch.save`` wrote to ``path``, each tensor a numpy array (a contiguous
    copy, of the tensor's dtype and shape).

    Args:
        path: The file.
        expected: What the file should be, for messages ("an h2h-racing policy file").

    Raises:
        FileNotFoundError: ``path`` is not a file.
        WeightsFileError: The file is empty, truncated or corrupt, or holds what a weights file
            does not (one line naming the file and what; nothing of it runs).
        DeferToTorch: The file may be one only torch reads (see the module docstring).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file; expected {expected}")
    with path.open("rb") as file:
        head = file.read(4)
    if not head:
        raise WeightsFileError(f"{path}: the file is empty (0 bytes); expected {expected}")
    if head != b"PK\x03\x04":
        raise DeferToTorch(f"{path}: not a zip archive (a legacy torch file, or no torch file)")
    try:
        with zipfile.ZipFile(path) as archive:
            return _read(archive, path, expected)
    except (DeferToTorch, WeightsFileError):
        raise
    except _Refused as refused:
        raise WeightsFileError(
            f"{path}: refused: {refused}; a weights file holds only tensors and plain values, "
            f"and reading anything else could run code; expected {expected}") from None
    except MemoryError:
        raise
    except Exception as error:  # zipfile and pickle raise many kinds (BadZipFile, EOFError, ...)
        raise WeightsFileError(
            f"{path}: cannot be read as a torch file ({type(error).__name__}: "
            f"{' '.join(str(error).split())[:200]}): it is truncated, corrupt or another kind "
            f"of file; expected {expected}") from None


def _read(archive: zipfile.ZipFile, path: Path, expected: str) -> Any:
    pickles = [info for info in archive.infolist()
               if info.filename.endswith("/data.pkl") and info.filename.count("/") == 1]
    if len(pickles) != 1:
        raise WeightsFileError(f"{path}: a zip archive with {len(pickles)} top-level data.pkl "
                               f"records, expected 1 as torch.save writes; expected {expected}")
    prefix = pickles[0].filename[:-len("data.pkl")]
    infos = {info.filename: info for info in archive.infolist()}
    if any(info.compress_type != zipfile.ZIP_STORED for info in infos.values()):
        raise DeferToTorch(f"{path}: compressed records (torch.save stores them uncompressed)")
    order = "little"
    if f"{prefix}byteorder" in infos:
        order = archive.read(f"{prefix}byteorder").decode("ascii", "replace")
        if order not in ("little", "big"):
            raise WeightsFileError(f"{path}: byteorder record {order[:20]!r}, expected 'little' "
                                   f"or 'big'; expected {expected}")
    storages: dict[str, np.ndarray] = {}

    def storage(pid: Any) -> tuple[np.ndarray, str]:
        if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage"):
            raise _Refused(f"a persistent reference {_short(pid)} (torch files hold "
                           f"('storage', type, key, location, numel) only)")
        _, kind, key, location, numel = pid
        if not (isinstance(kind, _StorageType) and isinstance(key, str)
                and isinstance(location, str) and type(numel) is int and numel >= 0):
            raise _Refused(f"a storage reference {_short(pid)} of unexpected types")
        name = f"{prefix}data/{key}"
        if key not in storages:
            if name not in infos:
                raise WeightsFileError(f"{path}: storage record {name!r} is missing (truncated "
                                       f"or corrupt); expected {expected}")
            dtype = kind.dtype.newbyteorder("<" if order == "little" else ">")
            raw = archive.read(name)
            if len(raw) < numel * dtype.itemsize:
                raise WeightsFileError(
                    f"{path}: storage record {name!r} holds {len(raw)} bytes, {numel} "
                    f"{kind.name} elements need {numel * dtype.itemsize} (truncated or "
                    f"corrupt); expected {expected}")
            data = np.frombuffer(raw, dtype=dtype, count=numel)
            storages[key] = data.astype(kind.dtype.newbyteorder("="), copy=True)
        if storages[key].dtype != kind.dtype:
            raise WeightsFileError(f"{path}: storage {key!r} is read as two dtypes; expected "
                                   f"{expected}")
        return storages[key], name

    unpickler = _Unpickler(io.BytesIO(archive.read(pickles[0].filename)), storage)
    return unpickler.load()


def _rebuild_tensor(stored: tuple[np.ndarray, str], offset: Any, size: Any, stride: Any,
                    requires_grad: Any, backward_hooks: Any, metadata: Any = None) -> np.ndarray:
    """``torch._utils._rebuild_tensor_v2`` as a numpy array: the view ``size``/``stride`` of
    the storage from element ``offset``, copied (contiguous)."""
    data, name = stored
    if not (type(offset) is int and offset >= 0 and isinstance(size, tuple)
            and isinstance(stride, tuple) and len(size) == len(stride)
            and all(type(n) is int and n >= 0 for n in size + stride)
            and isinstance(requires_grad, bool)):
        raise _Refused(f"a tensor of {name} with offset {_short(offset)}, size "
                       f"{_short(size)}, stride {_short(stride)} (expected whole numbers >= 0)")
    if not isinstance(backward_hooks, collections.OrderedDict) or backward_hooks:
        raise _Refused(f"a tensor of {name} with backward hooks {_short(backward_hooks)}")
    if metadata:
        raise DeferToTorch(f"a tensor of {name} with metadata {_short(metadata)}")
    if 0 in size:
        return np.zeros(size, dtype=data.dtype)
    last = offset + sum((n - 1) * s for n, s in zip(size, stride))
    if last >= data.size:
        raise _Refused(f"a tensor of {name} reaching element {last} of a storage of "
                       f"{data.size} (a corrupt file)")
    view = np.lib.stride_tricks.as_strided(data[offset:], shape=size,
                                           strides=[s * data.itemsize for s in stride],
                                           writeable=False)
    return np.array(view, order="C", copy=True)


class _Unpickler(pickle._Unpickler):  # type: ignore[name-defined]
    """``pickle._Unpickler`` with ``_OPCODES`` only, the globals of a weights file only, and
    ``REDUCE`` calling only those."""

    def __init__(self, file: io.BytesIO, storage: Any) -> None:
        super().__init__(file)
        self._storage = storage

    def find_class(self, module: str, name: str) -> Any:
        # Protocol 2 (torch.save's) writes Python 2's names, as pickle and torch map back.
        if (module, name) in _compat_pickle.NAME_MAPPING:
            module, name = _compat_pickle.NAME_MAPPING[(module, name)]
        module = _compat_pickle.IMPORT_MAPPING.get(module, module)
        full = f"{module}.{name}"
        if full == "collections.OrderedDict":
            return collections.OrderedDict
        if full == "torch._utils._rebuild_tensor_v2":
            return _rebuild_tensor
        if module == "torch" and name in STORAGE_DTYPES:
            return _StorageType(name)
        if module == "torch" or module.startswith("torch.") or full in TORCH_READS:
            raise DeferToTorch(f"global {full}")
        raise _Refused(f"the pickle names the global {full}")

    def persistent_load(self, pid: Any) -> Any:
        return self._storage(pid)

    def _reduce(self) -> None:
        args = self.stack.pop()
        func = self.stack[-1]
        if not (func is collections.OrderedDict or func is _rebuild_tensor):
            raise _Refused(f"a call of {_short(func)}")
        if not isinstance(args, tuple):
            raise _Refused(f"a call with arguments {_short(args)}")
        if func is collections.OrderedDict and args:
            raise _Refused("an OrderedDict built from arguments")
        self.stack[-1] = func(*args)

    def _build(self) -> None:
        # torch pickles an OrderedDict with its attributes (a state dict's _metadata): they go
        # to its __dict__, as pickle's own BUILD does; on anything else BUILD would call its
        # __setstate__.
        state = self.stack.pop()
        inst = self.stack[-1]
        if not (type(inst) is collections.OrderedDict and isinstance(state, dict)
                and all(type(k) is str for k in state)):
            raise _Refused(f"a BUILD of {type(inst).__name__} with {_short(state)}")
        inst.__dict__.update(state)



_OPCODE_NAMES = {value[0]: name for name, value in vars(pickle).items()
                 if name.isupper() and isinstance(value, bytes) and len(value) == 1}


def _refuser(code: int) -> Any:
    name = _OPCODE_NAMES.get(code, f"0x{code:02x}")

    def refuse(self: _Unpickler) -> None:
        raise _Refused(f"pickle opcode {name} (it builds objects of classes, or is no opcode)")

    return refuse


_ALLOWED = {getattr(pickle, name)[0] for name in _OPCODES}
_Unpickler.dispatch = {code: pickle._Unpickler.dispatch[code]  # type: ignore[attr-defined]
                       if code in _ALLOWED else _refuser(code) for code in range(256)}
_Unpickler.dispatch[pickle.REDUCE[0]] = _Unpickler._reduce
_Unpickler.dispatch[pickle.BUILD[0]] = _Unpickler._build


def _short(value: Any) -> str:
    """``repr(value)``, cut to 60 characters for a one-line message."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."

