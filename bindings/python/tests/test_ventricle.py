"""Issue 29's horn on a real scan: from a sphere in the frontal horn of
Colin27's left lateral ventricle (dark CSF in a T1 MRI), the mesh follows the
ventricle by default, because the box around the sphere sees its boundary
(grey_respacing's automatic setting, intensity_model.h); with free growth off
it stays in the horn. The ventricle is not labelled in AAL: its truth here is
the dark voxels (below 50) deep in the brain (8 voxels inside ch2bet), on the
sphere's side of the midline, connected to the sphere's centre. The right
ventricle's mesh used to come to rest while still growing (Dice 0.697 from
its frontal horn); a freely growing mesh now rests at a tenth of
convergence_mm (deform/convergence.cpp), and the CLI refines it to the
resolution its stretched quads ask for."""
import json
import os

import numpy as np

from conftest import MRI, need_mricron, run_cli

CENTRE = (-5.0, 22.0, 7.0)  # mm, RAS: the left frontal horn
RIGHT = (5.0, 22.0, 7.0)  # the right one
RADIUS = 3.0


def erode(mask, times):
    m = mask.copy()
    for _ in range(times):
        e = m.copy()
        e[1:] &= m[:-1]; e[:-1] &= m[1:]
        e[:, 1:] &= m[:, :-1]; e[:, :-1] &= m[:, 1:]
        e[:, :, 1:] &= m[:, :, :-1]; e[:, :, :-1] &= m[:, :, 1:]
        e[0] = e[-1] = False; e[:, 0] = e[:, -1] = False; e[:, :, 0] = e[:, :, -1] = False
        m = e
    return m


def component(mask, seed):
    """The 6-connected component of mask holding seed (index tuple)."""
    c = np.zeros_like(mask)
    c[seed] = True
    while True:
        g = c.copy()
        g[1:] |= c[:-1]; g[:-1] |= c[1:]
        g[:, 1:] |= c[:, :-1]; g[:, :-1] |= c[:, 1:]
        g[:, :, 1:] |= c[:, :, :-1]; g[:, :, :-1] |= c[:, :, 1:]
        g &= mask
        if g.sum() == c.sum():
            return c
        c = g


def ventricle(centre=CENTRE):
    import nibabel
    img = nibabel.load(f"{MRI}/ch2.nii.gz")
    t1 = np.asarray(img.dataobj, dtype=np.float64)
    brain = np.asarray(nibabel.load(f"{MRI}/ch2bet.nii.gz").dataobj) > 0
    A = img.affine
    x_mm = A[0, 0] * np.arange(t1.shape[0]) + A[0, 3]
    side = (x_mm < -1) if centre[0] < 0 else (x_mm > 1)
    dark = (t1 < 50) & erode(brain, 8) & side[:, None, None]
    seed = tuple(int(round(v)) for v in np.linalg.solve(A, np.r_[centre, 1.0])[:3])
    assert dark[seed], "the sphere's centre is not in the dark ventricle"
    return component(dark, seed), img


def run(tmp_path, name, *extra, centre=CENTRE):
    out = tmp_path / name
    r = run_cli("segment", f"{MRI}/ch2.nii.gz", "--sphere", ",".join(map(str, (*centre, RADIUS))),
                "--names", "ventricle_L", "--out", out, *extra)
    import nibabel
    seg = np.asarray(nibabel.load(str(out / "labels.nii.gz")).dataobj) > 0
    return r, json.loads((out / "report.json").read_text())["objects"][0], seg


def test_the_mesh_follows_the_lateral_ventricle_from_its_frontal_horn(tmp_path):
    need_mricron()
    truth, img = ventricle()
    assert 5000 < truth.sum() < 15000  # 9.6 ml
    dice = lambda m: 2 * (m & truth).sum() / (m.sum() + truth.sum())
    r, o, seg = run(tmp_path, "auto")
    assert o["grows_freely"] is True and o["respaced_steps"] > 10
    assert "grew freely" in r.stderr
    assert dice(seg) >= 0.84  # 0.857 measured (0.301 with free growth off; 0.833 kept at n = 12)
    # Its quads stretched along the ventricle ask for a finer mesh than its
    # area does (tools/cli/mesh_resolution.h): the first run is refined.
    report = json.loads((tmp_path / "auto" / "report.json").read_text())
    cfg = report["config"]
    assert cfg["first_mesh_resolution"] == 12 and cfg["refined_from_first_run"] is True
    assert cfg["mesh_resolution"] > 18 and cfg["asked_mesh_resolution"] == cfg["mesh_resolution"]
    r2, o2, seg2 = run(tmp_path, "never", "--param", "grey_respacing=2")
    assert o2["grows_freely"] is False and o2["respaced_steps"] == 0
    assert dice(seg2) < 0.5
    assert seg.sum() > 2 * seg2.sum()


def test_the_right_ventricle_grows_until_it_no_longer_moves(tmp_path):
    need_mricron()
    truth, img = ventricle(RIGHT)
    assert 5000 < truth.sum() < 15000  # 8.0 ml
    r, o, seg = run(tmp_path, "right", centre=RIGHT)
    assert o["grows_freely"] is True
    dice = 2 * (seg & truth).sum() / (seg.sum() + truth.sum())
    assert dice >= 0.86  # 0.877 measured (0.697 when it rested at convergence_mm, 0.853 kept at n = 12)
