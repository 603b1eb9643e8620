"""The Python module gives the `ffseg segment` tool's Colin27 result to the last
voxel and the same mesh (PEERS protocol sphere, n = 12, putamen L)."""
import json
import os

import numpy as np

from conftest import MRI, need_mricron, run_cli

import ffseg


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    assert "format binary_little_endian 1.0" in header
    nv = int(next(h for h in header if h.startswith("element vertex")).split()[2])
    nt = int(next(h for h in header if h.startswith("element face")).split()[2])
    xyz = np.frombuffer(data, "<f4", 3 * nv, end).reshape(nv, 3)
    faces = np.frombuffer(data, np.dtype([("n", "u1"), ("v", "<i4", 3)]), nt, end + 12 * nv)
    assert (faces["n"] == 3).all()
    return xyz, faces["v"].astype(np.uint32)


def test_python_matches_the_cli_on_colin27(tmp_path):
    need_mricron()
    import nibabel
    out = tmp_path / "putamen_L"
    run_cli("segment", f"{MRI}/ch2.nii.gz", "--sphere-from-label", f"{MRI}/aal.nii.gz:73",
            "--mesh-resolution", "12", "--names", "putamen_L", "--out", out, "-q")
    report = json.loads((out / "report.json").read_text())
    sphere = report["objects"][0]["sphere"]

    img = nibabel.load(f"{MRI}/ch2.nii.gz")
    raw = np.asarray(img.dataobj.get_unscaled())
    slope = img.dataobj.slope if np.isfinite(img.dataobj.slope) and img.dataobj.slope != 0 else 1.0
    inter = img.dataobj.inter if np.isfinite(img.dataobj.inter) else 0.0
    np.testing.assert_allclose(img.affine, np.array(report["input"]["index_to_world"]), atol=1e-6)
    masks, meshes = ffseg.segment(raw, img.affine, [(sphere["center_mm"], sphere["radius_mm"])],
                                  target_mode="intensity", mesh_resolution=12, max_steps=200,
                                  rescale_slope=slope, rescale_intercept=inter, return_meshes=True)
    labels = np.asarray(nibabel.load(str(out / "labels.nii.gz")).dataobj)
    # A --sphere-from-label object is labelled with its own label (73) in labels.nii.gz.
    assert report["objects"][0]["label"] == 73
    cli_mask = (labels == 73).astype(np.uint8)
    assert cli_mask.sum() == report["objects"][0]["voxels"] > 1000
    assert masks[0].shape == cli_mask.shape
    assert int((masks[0] != cli_mask).sum()) == 0

    xyz, tris = meshes[0]
    cli_xyz, cli_tris = read_ply(out / "putamen_L.ply")
    assert np.array_equal(xyz, cli_xyz)
    assert np.array_equal(tris, cli_tris)
    # A real deformation happened (not the initial sphere).
    r = np.linalg.norm(xyz - np.array(sphere["center_mm"], np.float32), axis=1)
    assert r.max() > 2 * sphere["radius_mm"]
