#!/usr/bin/python3
"""Organs cut by the scan's first or last slice (issue 30: a partial scan).

The shared CT (../shared/data/abdomen_ct) is cropped so that the grid's
first or last slice along z, x or y cuts through an organ; the crop keeps the
affine consistent (the origin moves to the first kept voxel's centre). Each
crop is segmented with the CLI's defaults from the cropped label's protocol
sphere (`ffseg segment CROP --sphere-from-label crop_labels:ID`), and
compared with
  - the cropped label (Dice "crop"),
  - the full scan's segmentation of the same organ restricted to the crop's
    grid, itself against the cropped label (Dice "full|crop": what the same
    engine reaches on that part when the organ is whole in the scan), and the
    two results with each other (Dice "vs full").
The mesh is checked against the crop's grid: vertices outside the grid's box
[-0.5, dims - 0.5] (index space; count and the farthest, in mm), and the
volume the closed mesh encloses against the label map's (a mesh that goes on
beyond the grid encloses volume no voxel holds).

usage: scripts/partial_scan.py [--cli build/ffseg] [--work DIR] [--cases liver_top13,...]
Needs /usr/bin/python3 with numpy and nibabel.
"""
import argparse
import json
import os
import struct
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "abdomen_ct"))

# (name, organ id, axis, side, fraction): the crop's edge slice cuts the organ
# `fraction` of its extent along `axis` in from its `side` end ("hi": the
# grid's last slice, e.g. z = superior; "lo": its first). The full scan is
# 122 x 101 x 112 (RAS: +x left, +y anterior, +z superior).
CASES = [
    ("liver_top13", 5, 2, "hi", 1 / 3),     # last z slice 1/3 down from the liver's top
    ("liver_top23", 5, 2, "hi", 2 / 3),
    ("liver_bottom13", 5, 2, "lo", 1 / 3),  # first z slice 1/3 up from the liver's bottom
    ("liver_x", 5, 0, "lo", 1 / 3),         # first x slice through the liver
    ("liver_y", 5, 1, "hi", 1 / 3),         # last y slice (anterior) through the liver
    ("spleen_top", 1, 2, "hi", 1 / 3),
    ("kidney_r_bottom", 2, 2, "lo", 1 / 3),
    ("kidney_l_top", 3, 2, "hi", 1 / 3),
    ("bladder_bottom", 104, 2, "lo", 1 / 3),
]
NAMES = {5: "liver", 1: "spleen", 2: "kidney_right", 3: "kidney_left", 104: "urinary_bladder"}


def crop_box(labels, organ, axis, side, fraction):
    """The kept index range [lo, hi) per axis: the whole grid but along axis."""
    w = np.argwhere(labels == organ)
    a, b = w[:, axis].min(), w[:, axis].max()
    cut = int(round(fraction * (b - a + 1)))
    lo, hi = [0, 0, 0], list(labels.shape)
    if side == "hi":
        hi[axis] = b + 1 - cut
    else:
        lo[axis] = a + cut
    return lo, hi


def make_crop(case, work):
    import nibabel as nib
    name, organ, axis, side, fraction = case
    out = os.path.join(work, name)
    ct_path, lab_path = os.path.join(out, "ct.nii.gz"), os.path.join(out, "labels.nii.gz")
    ct = nib.load(os.path.join(DATA, "ct.nii.gz"))
    lab = nib.load(os.path.join(DATA, "labels.nii.gz"))
    labels = np.asarray(lab.dataobj)
    lo, hi = crop_box(labels, organ, axis, side, fraction)
    if not (os.path.exists(ct_path) and os.path.exists(lab_path)):
        os.makedirs(out, exist_ok=True)
        a = np.asarray(ct.dataobj)
        A = ct.affine.copy()
        A[:3, 3] = A[:3, :3] @ np.array(lo, float) + A[:3, 3]  # the first kept voxel's centre
        s = tuple(slice(l, h) for l, h in zip(lo, hi))
        nib.save(nib.Nifti1Image(np.ascontiguousarray(a[s]), A), ct_path)
        nib.save(nib.Nifti1Image(np.ascontiguousarray(labels[s]), A), lab_path)
    return out, lo, hi


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    nv = int(header.split("element vertex ")[1].split()[0])
    nt = int(header.split("element face ")[1].split()[0])
    xyz = np.frombuffer(data, np.float32, 3 * nv, end).reshape(nv, 3).astype(float)
    rec = np.frombuffer(data, np.dtype([("n", "u1"), ("v", "<u4", 3)]), nt, end + 12 * nv)
    return xyz, rec["v"].astype(np.int64)


def mesh_volume_ml(xyz, tris):
    a, b, c = xyz[tris[:, 0]], xyz[tris[:, 1]], xyz[tris[:, 2]]
    return abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6 / 1000


def segment(cli, ct, lab, organ, out):
    cmd = [cli, "segment", ct, "--sphere-from-label", f"{lab}:{organ}", "--truth", lab,
           "--names", NAMES[organ], "--out", out, "--force", "--quiet"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode not in (0, 6):
        return None, f"exit {r.returncode}: {r.stderr.strip()[-300:]}"
    rep = json.load(open(os.path.join(out, "report.json")))
    return rep, r.returncode


def dice(a, b):
    s = a.sum() + b.sum()
    return 2 * np.logical_and(a, b).sum() / s if s else 1.0


def main():
    import nibabel as nib
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cli", default=os.path.join(ROOT, "build", "ffseg"))
    ap.add_argument("--work", default="/tmp/ffseg-partial-scan")
    ap.add_argument("--cases", default="", help="case names, comma-separated (default: all)")
    args = ap.parse_args()
    if not os.path.isdir(DATA):
        sys.exit(f"partial_scan: {DATA} is absent (the shared data beside the repository)")
    cases = CASES
    if args.cases:
        wanted = args.cases.split(",")
        cases = [c for c in CASES if c[0] in wanted]
    os.makedirs(args.work, exist_ok=True)
    full_lab = os.path.join(DATA, "labels.nii.gz")
    full = {}
    print("| case | organ | crop dims | Dice crop | Dice full|crop | Dice vs full | ml / label ml | "
          "mesh ml | vertices outside grid (max mm) | steps | stalled | exit |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for case in cases:
        name, organ = case[0], case[1]
        if organ not in full:
            out = os.path.join(args.work, f"full_{organ}")
            rep, code = segment(args.cli, os.path.join(DATA, "ct.nii.gz"), full_lab, organ, out)
            if rep is None:
                sys.exit(f"full scan, organ {organ}: {code}")
            full[organ] = np.asarray(nib.load(os.path.join(out, "labels.nii.gz")).dataobj) != 0
        d, lo, hi = make_crop(case, args.work)
        ct, lab = os.path.join(d, "ct.nii.gz"), os.path.join(d, "labels.nii.gz")
        out = os.path.join(d, "out")
        rep, code = segment(args.cli, ct, lab, organ, out)
        if rep is None:
            print(f"| {name} | {organ} | | {code} |")
            continue
        truth = np.asarray(nib.load(lab).dataobj) == organ
        img = nib.load(os.path.join(out, "labels.nii.gz"))
        pred = np.asarray(img.dataobj) != 0
        s = tuple(slice(l, h) for l, h in zip(lo, hi))
        full_crop = full[organ][s]
        o = rep["objects"][0]
        xyz, tris = read_ply(os.path.join(out, f"{NAMES[organ]}.ply"))
        inv = np.linalg.inv(img.affine)
        ijk = xyz @ inv[:3, :3].T + inv[:3, 3]
        dims = np.array(truth.shape)
        below, above = np.maximum(-0.5 - ijk, 0), np.maximum(ijk - (dims - 0.5), 0)
        beyond_mm = np.abs(np.maximum(below, above)) * np.abs(np.diag(img.affine)[:3])
        outside = (beyond_mm.max(1) > 1e-3).sum()
        print(f"| {name} | {NAMES[organ]} | {'x'.join(map(str, truth.shape))} | {dice(pred, truth):.3f} | "
              f"{dice(full_crop, truth):.3f} | {dice(pred, full_crop):.3f} | "
              f"{pred.sum() * 27 / 1000:.0f} / {truth.sum() * 27 / 1000:.0f} | {mesh_volume_ml(xyz, tris):.0f} | "
              f"{outside} ({beyond_mm.max():.1f}) | {rep['steps']} | {'yes' if o.get('stalled') else 'no'} | "
              f"{code} |", flush=True)


if __name__ == "__main__":
    main()
