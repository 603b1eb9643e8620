"""Shared pieces of the Python tests. Run with the interpreter that has
Debian's numpy, pytest and distributed (/usr/bin/python3): `make check-python`,
or ctest's `python` test, which also names the freshly built library."""
import os
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
sys.path.insert(0, os.path.dirname(HERE))  # bindings/python: `import ffseg` from the tree

MRI = "/usr/share/mricron/templates"


def stored_values(img):
    """A nibabel image's voxels as stored, with the slope and intercept the
    tool applies (1 and 0 where the header leaves them undefined): what
    ffseg.segment() takes to read the volume as the tool does."""
    raw = np.asarray(img.dataobj.get_unscaled())
    slope = img.dataobj.slope if np.isfinite(img.dataobj.slope) and img.dataobj.slope != 0 else 1.0
    inter = img.dataobj.inter if np.isfinite(img.dataobj.inter) else 0.0
    return raw, slope, inter


def cli_path():
    p = os.environ.get("FFSEG_CLI") or os.path.join(ROOT, "build", "ffseg")
    if not os.path.exists(p):
        pytest.fail(f"the ffseg tool was not found at {p}: build it (make) or set FFSEG_CLI")
    return p


def run_cli(*args, check=True):
    r = subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True)
    if check and r.returncode != 0:
        raise AssertionError(f"ffseg {' '.join(map(str, args))} exited {r.returncode}: {r.stderr}")
    return r


def ball(shape=(40, 36, 32), centre=(20.0, 17.0, 15.5), radius=9.0, dtype=np.uint8,
         inside=200, outside=0, noise=0.0, seed=1):
    """A bright ball in a dark box, array[i, j, k]; voxel centres at the integer indices."""
    i, j, k = np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij")
    d = np.sqrt((i - centre[0]) ** 2 + (j - centre[1]) ** 2 + (k - centre[2]) ** 2)
    v = np.where(d <= radius, float(inside), float(outside))
    if noise:
        v += np.random.default_rng(seed).normal(0, noise, shape)
    info = np.iinfo(dtype) if np.issubdtype(dtype, np.integer) else None
    if info:
        v = np.clip(np.rint(v), info.min, info.max)
    return v.astype(dtype)


def affine(spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)):
    A = np.eye(4)
    A[:3, :3] = np.diag(spacing)
    A[:3, 3] = origin
    return A


def need_mricron():
    if not os.path.exists(os.path.join(MRI, "ch2.nii.gz")):
        pytest.skip(f"Colin27 ({MRI}, Debian mricron-data) is not installed: `make deps`")
