"""The ctypes mirror (ffseg/_abi.py) against the C compiler's layout of ffseg.h:
a field appended to a struct in the header fails here until the mirror has it."""
import ctypes
import os
import subprocess

import pytest

import conftest  # noqa: F401  (import path)
from ffseg import _abi


def c_layout():
    exe = os.environ.get("FFSEG_ABI_LAYOUT") or os.path.join(conftest.ROOT, "build", "ffseg_abi_layout")
    if not os.path.exists(exe):
        pytest.fail(f"{exe} not found: build the ffseg_abi_layout target or set FFSEG_ABI_LAYOUT")
    out = subprocess.run([exe], capture_output=True, text=True, check=True).stdout
    sizes, fields, consts = {}, {}, {}
    for line in out.splitlines():
        w = line.split()
        if w[0] == "const":
            consts[w[1]] = int(w[2])
        elif w[1] == "sizeof":
            sizes[w[0]] = int(w[2])
        else:
            fields.setdefault(w[0], []).append((w[1], int(w[2]), int(w[3])))
    return sizes, fields, consts


def test_struct_sizes_and_offsets_match_the_c_compiler():
    sizes, fields, _ = c_layout()
    assert set(sizes) == set(_abi.STRUCTS)
    for cname, py in _abi.STRUCTS.items():
        assert ctypes.sizeof(py) == sizes[cname], f"{cname}: ctypes {ctypes.sizeof(py)} bytes, C {sizes[cname]}"
        mirror = [(n, getattr(py, n).offset, getattr(py, n).size) for n, _ in py._fields_]
        assert mirror == fields[cname], f"{cname}: field names, offsets or sizes differ"


def test_constants_match_the_header():
    _, _, c = c_layout()
    assert c["FFSEG_STAGE_COUNT"] == _abi.STAGE_COUNT == len(_abi.STAGE_NAMES)
    assert c["FFSEG_REPORT_OBJECTS"] == _abi.REPORT_OBJECTS
    assert c["FFSEG_TARGET_BINARY"] == _abi.TARGET_BINARY
    assert c["FFSEG_TARGET_INTENSITY"] == _abi.TARGET_INTENSITY
    assert c["FFSEG_CONVERGED"] == _abi.CONVERGED
    assert c["FFSEG_DEGENERATE"] == _abi.DEGENERATE
    assert c["FFSEG_OBJECT_NO_BOUNDARY"] == _abi.OBJECT_NO_BOUNDARY
    assert c["FFSEG_OBJECT_FILLS_GRID"] == _abi.OBJECT_FILLS_GRID
    assert c["FFSEG_OBJECT_STALLED"] == _abi.OBJECT_STALLED
    assert [c[f"FFSEG_{t}"] for t in ("U8", "I16", "U16", "I32", "F32", "F64")] == \
        [_abi.U8, _abi.I16, _abi.U16, _abi.I32, _abi.F32, _abi.F64]
