"""The Python module gives the `ffseg segment` tool's Colin27 result to the last
voxel and the same mesh (PEERS protocol sphere, n = 12, putamen L)."""
import json
import os

import numpy as np

from conftest import MRI, need_mricron, run_cli, stored_values

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
    raw, slope, inter = stored_values(img)
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


def test_python_makes_the_tools_runs_at_a_fine_resolution_eight_nuclei(tmp_path):
    """Above n = 12 segment() makes the tool's runs: a first run at n = 12,
    then n from its meshes (coarse to fine), the larger organs placed first,
    an object that stalls at n put back on its n = 12 surface. Colin27's eight
    deep nuclei at n = 33 (eight neighbours whose resampled meshes may touch),
    and the label map must be the tool's voxel for voxel; before, segment()
    made one run from the spheres at n = 33."""
    need_mricron()
    import nibabel
    labels = [71, 72, 73, 74, 75, 76, 77, 78]
    out = tmp_path / "nuclei"
    args = ["segment", f"{MRI}/ch2.nii.gz", "--mesh-resolution", "33", "--out", out, "-q"]
    for label in labels:
        args += ["--sphere-from-label", f"{MRI}/aal.nii.gz:{label}"]
    run_cli(*args)
    report = json.loads((out / "report.json").read_text())
    assert report["passes"] == 2 and report["config"]["refined_from_first_run"]
    assert "first run" in {o["started_from"] for o in report["objects"]}

    img = nibabel.load(f"{MRI}/ch2.nii.gz")
    raw, slope, inter = stored_values(img)
    spheres = [(o["sphere"]["center_mm"], o["sphere"]["radius_mm"]) for o in report["objects"]]
    masks = ffseg.segment(raw, img.affine, spheres, mesh_resolution=33, rescale_slope=slope, rescale_intercept=inter)
    cli = np.asarray(nibabel.load(str(out / "labels.nii.gz")).dataobj)
    mine = np.zeros(cli.shape, cli.dtype)
    for label, m in reversed(list(zip(labels, masks))):  # a voxel inside two meshes: the first object's
        mine[m != 0] = label
    assert int((mine != cli).sum()) == 0
