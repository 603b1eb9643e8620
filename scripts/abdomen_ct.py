#!/usr/bin/python3
"""The abdominal CT protocol (issues 29 and 30): organs of ../shared/data/abdomen_ct
segmented from their protocol spheres, on the 3 mm scan and on the same scan
resampled to 1 mm, the way a scanner's 0.7-1 mm grid looks to the mesh.

Each organ runs alone with the CLI's defaults (`ffseg segment CT
--sphere-from-label labels.nii.gz:ID --truth labels.nii.gz`), or with
--resolution N a fixed mesh resolution; printed per organ: its set (the
issue's choosing or reporting set), Dice, ASSD, HD95, volume against the
label, steps and seconds of stepping (the last pass's, and in brackets all
passes': the first run at n = 12 and the finer run from its meshes), the
mesh resolution and whether it stalled; then the means per set.

The 1 mm grid is made here: trilinear for the CT (rounded to int16, as a
scanner stores it), nearest neighbour for the labels, voxel edges kept where
they were (the 3 mm voxel (i, j, k) becomes the 3 x 3 x 3 block
3i..3i+2 ...; the fine voxel centres are at (3i + 1) of the 3 mm ones).
--spacing 3x3x1 resamples the slices alone (3 x 3 x 1 mm: thick slices
reformatted into thin ones, the noise oversampled along one axis).
Written once into --work (default /tmp/ffseg-abdomen-ct).

usage: scripts/abdomen_ct.py [--spacing 3|1|both|XxYxZ] [--organs 5,1,...] [--together]
                             [--resolution auto|N] [--jitter K] [--noise SD] [--arterial]
                             [--cli build/ffseg] [--work DIR]
Needs /usr/bin/python3 with numpy and nibabel (Debian python3-numpy, python3-nibabel).
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "abdomen_ct"))

# Issue 30's sets: choose on the first, report on the second.
CHOOSING = [(5, "liver"), (1, "spleen"), (3, "kidney left"), (4, "gallbladder"), (7, "aorta"),
            (102, "iliopsoas left"), (96, "gluteus medius left")]
REPORTING = [(2, "kidney right"), (6, "stomach"), (8, "vena cava"), (10, "pancreas"),
             (104, "urinary bladder"), (103, "iliopsoas right"), (97, "gluteus medius right"),
             (100, "autochthon left"), (101, "autochthon right")]


def noisier(sd, work):
    """The shared CT with white noise of sd HU added (numpy seed 1), as a
    noisier acquisition of the same anatomy, beside its labels; returns the
    directory."""
    import nibabel as nib
    out = os.path.join(work, f"noise{sd:g}")
    ct_path, lab_path = os.path.join(out, "ct.nii.gz"), os.path.join(out, "labels.nii.gz")
    if os.path.exists(ct_path) and os.path.exists(lab_path):
        return out
    os.makedirs(out, exist_ok=True)
    ct = nib.load(os.path.join(DATA, "ct.nii.gz"))
    a = np.asarray(ct.dataobj).astype(np.float64)
    a += np.random.default_rng(1).normal(0, sd, a.shape)
    nib.save(nib.Nifti1Image(np.rint(a).astype(np.int16), ct.affine), ct_path)
    shutil.copyfile(os.path.join(DATA, "labels.nii.gz"), lab_path)
    return out


# An arterial phase laid onto the non-contrast scan (HU added inside each
# label): iodine reaches the aorta first (about 300 HU there), the renal
# cortex and the spleen next, the liver and the portal vein little, the
# inferior vena cava below the kidneys not yet. Rough figures of a typical
# arterial phase, not a model of one; what matters is that a vessel then has
# a grey level of its own while bone keeps its own (the aorta lies on the
# vertebral bodies).
ARTERIAL_HU = {7: 250, 2: 100, 3: 100, 1: 60, 9: 60, 5: 20}


def blurred(a, sigma):
    """a smoothed by a separable Gaussian of sigma voxels (numpy only): the
    enhancement's edge spread over the scanner's point spread, as partial
    volume."""
    r = int(np.ceil(3 * sigma))
    w = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    w /= w.sum()
    for ax in range(3):
        a = np.apply_along_axis(lambda v: np.convolve(np.pad(v, r, mode="edge"), w, mode="valid"), ax, a)
    return a


def arterial(work, src=DATA):
    """The scan of src with ARTERIAL_HU added inside its labels (blurred by
    0.6 voxel, rounded to int16), beside its labels: a phantom of a
    contrast-enhanced CT on the same anatomy (issue 29: a vessel of its own
    grey level); returns the directory."""
    import nibabel as nib
    out = os.path.join(work, "arterial" if src == DATA else os.path.basename(src) + "_arterial")
    ct_path, lab_path = os.path.join(out, "ct.nii.gz"), os.path.join(out, "labels.nii.gz")
    if os.path.exists(ct_path) and os.path.exists(lab_path):
        return out
    os.makedirs(out, exist_ok=True)
    ct = nib.load(os.path.join(src, "ct.nii.gz"))
    labels = np.asarray(nib.load(os.path.join(src, "labels.nii.gz")).dataobj)
    add = np.zeros(labels.shape)
    for organ, hu in ARTERIAL_HU.items():
        add[labels == organ] = hu
    a = np.asarray(ct.dataobj).astype(np.float64) + blurred(add, 0.6)
    nib.save(nib.Nifti1Image(np.rint(a).astype(np.int16), ct.affine), ct_path)
    shutil.copyfile(os.path.join(src, "labels.nii.gz"), lab_path)
    return out


def resample(factor, work, src=DATA):
    """The CT and labels of src (default: the shared CT) on a grid `factor`
    times finer (one factor, or one per axis); returns the directory."""
    import nibabel as nib
    fs = tuple(factor) if isinstance(factor, (tuple, list)) else (factor,) * 3
    name = f"{fs[0]}x" if len(set(fs)) == 1 else "x".join(str(f) for f in fs)
    if src != DATA:
        name = os.path.basename(src) + "_" + name
    out = os.path.join(work, name)
    ct_path, lab_path = os.path.join(out, "ct.nii.gz"), os.path.join(out, "labels.nii.gz")
    if os.path.exists(ct_path) and os.path.exists(lab_path):
        return out
    os.makedirs(out, exist_ok=True)
    ct = nib.load(os.path.join(src, "ct.nii.gz"))
    lab = nib.load(os.path.join(src, "labels.nii.gz"))
    a = np.asarray(ct.dataobj).astype(np.float32)
    labels = np.asarray(lab.dataobj)

    def axis(n, f):
        j = np.arange(n * f)
        x = np.clip((j - (f - 1) / 2) / f, 0, n - 1)  # fine centre in coarse index units
        i0 = np.minimum(np.floor(x).astype(int), n - 2)
        near = np.clip(np.rint((j - (f - 1) / 2) / f).astype(int), 0, n - 1)
        return i0, (x - i0).astype(np.float32), near

    (i0, wi, ni), (j0, wj, nj), (k0, wk, nk) = [axis(n, f) for n, f in zip(a.shape, fs)]
    t = a[i0] * (1 - wi)[:, None, None] + a[i0 + 1] * wi[:, None, None]
    t = t[:, j0] * (1 - wj)[None, :, None] + t[:, j0 + 1] * wj[None, :, None]
    t = t[:, :, k0] * (1 - wk)[None, None, :] + t[:, :, k0 + 1] * wk[None, None, :]
    fine_labels = labels[ni][:, nj][:, :, nk]
    A = ct.affine.copy()
    S = A[:3, :3].copy()
    f = np.asarray(fs, dtype=float)
    A[:3, :3] = S / f
    A[:3, 3] = A[:3, 3] - S @ ((f - 1) / (2 * f))  # the first fine centre
    nib.save(nib.Nifti1Image(np.rint(t).astype(np.int16), A), ct_path)
    nib.save(nib.Nifti1Image(fine_labels.astype(np.uint8), A), lab_path)
    return out


def axis_factors(spacing):
    """Resampling factors of the 3 mm scan for a spacing "XxYxZ" (mm, each 1 or 3)."""
    mm = spacing.split("x")
    if len(mm) != 3 or any(m not in ("1", "3") for m in mm):
        sys.exit(f"abdomen_ct: --spacing {spacing}: expected 3, 1, both or XxYxZ with each of X, Y, Z 1 or 3")
    return tuple(3 // int(m) for m in mm)


def segment(cli, data_dir, organ, name, out, resolution, params=(), sphere=None):
    """One organ alone from its protocol sphere (or from `sphere`, x,y,z,r in
    world mm): the report's figures."""
    ct, lab = os.path.join(data_dir, "ct.nii.gz"), os.path.join(data_dir, "labels.nii.gz")
    seed = (["--sphere", ",".join(repr(float(v)) for v in sphere), "--truth-labels", str(organ)] if sphere
            else ["--sphere-from-label", f"{lab}:{organ}"])
    cmd = [cli, "segment", ct] + seed + ["--truth", lab,
           "--names", name.replace(" ", "_"), "--out", out, "--force", "--quiet"]
    if resolution != "auto":
        cmd += ["--mesh-resolution", str(resolution)]
    for p in params:
        cmd += ["--param", p]
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - t0
    if r.returncode not in (0, 6):
        return {"error": f"exit {r.returncode}: {r.stderr.strip()[-300:]}"}
    rep = json.load(open(os.path.join(out, "report.json")))
    o = rep["objects"][0]
    m = o["metrics"]
    return {"dice": m["dice"], "assd": m["assd_mm"], "hd95": m["hd95_mm"], "ml": o["volume_ml"],
            "label_ml": m["truth_volume_ml"], "steps": rep["steps"],
            "stepping_s": rep["time_ms"]["stepping"] / 1000, "wall_s": wall,
            "steps_all": rep.get("steps_all_passes", rep["steps"]),
            "stepping_all_s": rep["time_ms"].get("stepping_all_passes", rep["time_ms"]["stepping"]) / 1000,
            "n": rep["config"]["mesh_resolution"], "stalled": o.get("stalled", False),
            "sphere": list(o["sphere"]["center_mm"]) + [o["sphere"]["radius_mm"]]}


# --jitter: the protocol sphere moved by half its radius along these
# directions. The protocol's radius is half the centre's depth in the label,
# so every moved sphere still lies inside the organ. One scan's outcome for
# an organ that leaks or stalls swings with details (BENCHMARKS section 11:
# the vena cava 0.39-0.62 between variants), so a choice between variants
# reads the mean over the moved spheres as well as the protocol's figure.
JITTER_DIRECTIONS = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]


def moved_sphere(sphere, j):
    """sphere (x, y, z, r) moved by r / 2 along JITTER_DIRECTIONS[j]."""
    x, y, z, r = sphere
    d = JITTER_DIRECTIONS[j]
    return (x + d[0] * r / 2, y + d[1] * r / 2, z + d[2] * r / 2, r)


def below_alone(name, together, alone):
    """Issue 30's chapter 6 criterion: "name -0.0xx" when an organ's Dice
    together is below its Dice alone - 0.01, else None."""
    return f"{name} {together - alone:+.3f}" if alone is not None and together < alone - 0.01 else None


def jittered(cli, data_dir, organ, name, work, resolution, params, sphere, k):
    """Dice from the first k moved spheres, two runs at a time."""
    from concurrent.futures import ThreadPoolExecutor

    def one(j):
        res = segment(cli, data_dir, organ, name, os.path.join(work, f"jitter{j}"), resolution, params,
                      moved_sphere(sphere, j))
        return res.get("dice", 0.0)

    with ThreadPoolExecutor(max_workers=2) as pool:
        return list(pool.map(one, range(k)))


def segment_together(cli, data_dir, organs, out, params=(), spheres=None):
    """Every organ from its protocol sphere (or from spheres[i], x,y,z,r in
    world mm) in one engine (thesis chapter 6): the report's figures per
    organ, and the shared voxels."""
    ct, lab = os.path.join(data_dir, "ct.nii.gz"), os.path.join(data_dir, "labels.nii.gz")
    cmd = [cli, "segment", ct, "--truth", lab, "--out", out, "--force", "--quiet",
           "--names", ",".join(n.replace(" ", "_") for _, n, _ in organs)]
    for i, (organ, _, _) in enumerate(organs):
        if spheres:
            cmd += ["--sphere", ",".join(repr(float(v)) for v in spheres[i])]
        else:
            cmd += ["--sphere-from-label", f"{lab}:{organ}"]
    if spheres:
        cmd += ["--truth-labels", ",".join(str(organ) for organ, _, _ in organs)]
    for p in params:
        cmd += ["--param", p]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode not in (0, 6):
        sys.exit(f"together: exit {r.returncode}: {r.stderr.strip()[-400:]}")
    rep = json.load(open(os.path.join(out, "report.json")))
    res = []
    for o in rep["objects"]:
        m = o["metrics"]
        res.append({"dice": m["dice"], "assd": m["assd_mm"], "hd95": m["hd95_mm"], "ml": o["volume_ml"],
                    "label_ml": m["truth_volume_ml"], "stalled": o.get("stalled", False)})
    return res, rep


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spacing", default="3",
                    help="3 (the scan), 1 (resampled to 1 mm), both, or XxYxZ in mm, each "
                         "1 or 3 (e.g. 3x3x1: the slices alone resampled)")
    ap.add_argument("--organs", default="", help="label ids, comma-separated (default: both sets)")
    ap.add_argument("--resolution", default="auto")
    ap.add_argument("--cli", default=os.path.join(ROOT, "build", "ffseg"))
    ap.add_argument("--work", default="/tmp/ffseg-abdomen-ct")
    ap.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                    help="an engine parameter for every run (repeatable; ffseg segment --param)")
    ap.add_argument("--jitter", type=int, default=0, metavar="K",
                    help="also segment each organ alone from its sphere moved by half its radius "
                         "along K of +-x, +-y, +-z (K <= 6) and print the mean Dice over the 1 + K runs")
    ap.add_argument("--arterial", action="store_true",
                    help="the scan with an arterial phase laid on (arterial(): ARTERIAL_HU added inside "
                         "the labels), before any resampling")
    ap.add_argument("--noise", type=float, default=0, metavar="SD",
                    help="add white noise of SD HU to the scan first (numpy seed 1): a noisier "
                         "acquisition of the same anatomy")
    ap.add_argument("--together", action="store_true",
                    help="also every organ in one engine (chapter 6), against each alone")
    args = ap.parse_args()
    if not 0 <= args.jitter <= len(JITTER_DIRECTIONS):
        sys.exit(f"abdomen_ct: --jitter takes 0 to {len(JITTER_DIRECTIONS)}")
    if not os.path.isdir(DATA):
        sys.exit(f"abdomen_ct: {DATA} is absent (the shared data beside the repository)")
    organs = [(i, n, "choosing") for i, n in CHOOSING] + [(i, n, "reporting") for i, n in REPORTING]
    if args.organs:
        wanted = [int(x) for x in args.organs.split(",")]
        organs = [o for o in organs if o[0] in wanted]
    os.makedirs(args.work, exist_ok=True)
    spacings = ["3", "1"] if args.spacing == "both" else [args.spacing]
    for sp in spacings:
        # XxYxZ: the axes resampled one by one (3x3x1: the slices alone, as
        # thick slices reformatted into thin ones: the noise oversampled
        # along one axis).
        src = noisier(args.noise, args.work) if args.noise > 0 else DATA
        if args.arterial:
            src = arterial(args.work, src)
        data_dir = src if sp == "3" else resample(3 if sp == "1" else axis_factors(sp), args.work, src)
        print(f"\n{sp} mm grid ({data_dir}), mesh resolution {args.resolution}")
        jit_head = f" Dice over 1 + {args.jitter} spheres: mean (min-max) |" if args.jitter else ""
        print("| organ (id) | set | Dice | ASSD mm | HD95 mm | ml / label ml | steps (all passes) | "
              "stepping s (all passes) | n | stalled |" + jit_head)
        print("|---|---|---|---|---|---|---|---|---|---|" + ("---|" if args.jitter else ""))
        alone = {}  # organ -> its Dice alone, for the together table
        sphere_of = {}  # organ -> its protocol sphere, for --jitter together
        alone_jit = {}  # organ -> its mean Dice alone over the moved spheres
        for organ, name, which in organs:
            out = os.path.join(args.work, f"out_{sp}mm_{organ}")
            r = segment(args.cli, data_dir, organ, name, out, args.resolution, args.param)
            if "error" in r:
                print(f"| {name} ({organ}) | {which} | {r['error']} |")
                continue
            alone[organ] = r["dice"]
            sphere_of[organ] = r["sphere"]
            jit = ""
            if args.jitter:
                d = [r["dice"]] + jittered(args.cli, data_dir, organ, name, out, args.resolution, args.param,
                                           r["sphere"], args.jitter)
                alone_jit[organ] = np.mean(d)
                jit = f" {np.mean(d):.3f} ({min(d):.3f}-{max(d):.3f}) |"
            print(f"| {name} ({organ}) | {which} | {r['dice']:.3f} | {r['assd']:.2f} | {r['hd95']:.1f} | "
                  f"{r['ml']:.0f} / {r['label_ml']:.0f} | {r['steps']} ({r['steps_all']}) | "
                  f"{r['stepping_s']:.2f} ({r['stepping_all_s']:.2f}) | {r['n']} | "
                  f"{'yes' if r['stalled'] else 'no'} |" + jit, flush=True)
        def set_means(which_sets, label):
            d = [alone[o] for o, _, w in organs if w in which_sets and o in alone]
            if d:
                dj = [alone_jit[o] for o, _, w in organs if w in which_sets and o in alone_jit]
                print(f"mean Dice, {label}: {np.mean(d):.3f} over {len(d)}"
                      + (f"; over the moved spheres too: {np.mean(dj):.3f}" if dj else ""))
        for which in ("choosing", "reporting"):
            set_means((which,), f"{which} set")
        set_means(("choosing", "reporting"), "both sets")
        if args.together:
            res, rep = segment_together(args.cli, data_dir, organs, os.path.join(args.work, f"together_{sp}mm"), args.param)
            all_s = rep["time_ms"].get("stepping_all_passes", rep["time_ms"]["stepping"]) / 1000
            print(f"\ntogether in one engine: {rep['steps']} steps, {rep['time_ms']['stepping'] / 1000:.2f} s of "
                  f"stepping ({rep['time_ms']['stages']['regions'] / 1000:.2f} s of it bounding regions; all "
                  f"{rep.get('passes', 1)} passes: {rep.get('steps_all_passes', rep['steps'])} steps, {all_s:.2f} s), "
                  f"{rep.get('shared_voxels', 0)} shared voxels")
            # Issue 30's criteria for chapter 6: each organ at least its Dice
            # alone - 0.01, the mean at least the mean alone.
            print("| organ (id) | set | Dice together | alone | together - alone | ml / label ml | stalled |")
            print("|---|---|---|---|---|---|---|")
            below = []
            for (organ, name, which), r in zip(organs, res):
                a = alone.get(organ)
                diff = "" if a is None else f"{r['dice'] - a:+.3f}"
                below.append(below_alone(name, r["dice"], a))
                print(f"| {name} ({organ}) | {which} | {r['dice']:.3f} | {'' if a is None else f'{a:.3f}'} | {diff} | "
                      f"{r['ml']:.0f} / {r['label_ml']:.0f} | {'yes' if r['stalled'] else 'no'} |")
            together_mean = np.mean([r["dice"] for r in res])
            print(f"mean Dice together: {together_mean:.3f}"
                  + (f" (alone {np.mean(list(alone.values())):.3f})" if len(alone) == len(res) else ""))
            below = [b for b in below if b]
            print("below alone - 0.01: " + (", ".join(below) if below else "none"))
            if args.jitter and len(sphere_of) == len(organs):
                means = [together_mean]
                per_organ = [[r["dice"]] for r in res]
                for j in range(args.jitter):
                    moved = [moved_sphere(sphere_of[o], j) for o, _, _ in organs]
                    rj, _ = segment_together(args.cli, data_dir, organs,
                                             os.path.join(args.work, f"together_{sp}mm_jitter{j}"), args.param, moved)
                    means.append(np.mean([x["dice"] for x in rj]))
                    for i, x in enumerate(rj):
                        per_organ[i].append(x["dice"])
                print(f"mean Dice together over 1 + {args.jitter} placements (every sphere moved by half its "
                      f"radius along one axis direction): {np.mean(means):.3f} "
                      f"({' '.join(f'{m:.3f}' for m in means)})")
                # Issue 30's chapter 6 criterion on the means over the placements.
                print("| organ (id) | Dice together, mean over the placements | alone, the same | together - alone |")
                print("|---|---|---|---|")
                below = []
                for (organ, name, _), d in zip(organs, per_organ):
                    t, a = np.mean(d), alone_jit.get(organ)
                    below.append(below_alone(name, t, a))
                    print(f"| {name} ({organ}) | {t:.3f} | {'' if a is None else f'{a:.3f}'} | "
                          f"{'' if a is None else f'{t - a:+.3f}'} |")
                below = [b for b in below if b]
                print("below alone - 0.01 over the placements: " + (", ".join(below) if below else "none"))


if __name__ == "__main__":
    main()
