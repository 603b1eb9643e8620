#!/usr/bin/python3
"""How far can the mesh itself go on Colin27? (issue 19, accuracy)

For each AAL structure of the protocol, ffseg's mesh is grown from the
protocol sphere (--sphere-from-label) with the structure's own AAL label as
a binary target (chapter 4): the evidence is then perfect, and what is left
of the Dice against the label is the mesh's share of the error (its
resolution, regularisation, guard, rasterisation). Set beside the grey-level
runs (BENCHMARKS.md section 4), it says how much of the gap to issue 19's
0.70 is the mesh's and how much the evidence's.

  /usr/bin/python3 scripts/mesh_ceiling.py [FFSEG] [--mesh-resolution N]

FFSEG: the ffseg tool (default build/ffseg); N: 12 (the resolution of
the BENCHMARKS tables), or auto for the CLI's default. Reads
/usr/share/mricron/templates/aal.nii.gz (Debian mricron-data); writes the
0/1 label maps and ffseg's outputs into a temporary directory, removed at
the end. numpy and nibabel only.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

try:
    import nibabel as nib
except ImportError:
    sys.exit("mesh_ceiling: needs python3-nibabel (make deps)")

from colin27_protocol import MRI, STRUCTURES  # noqa: E402 (scripts/colin27_protocol.py)


def run_one(ffseg, aal_path, aal, label, resolution, work):
    """Dice, ASSD (mm) and volume (ml) of the mesh grown onto label's own 0/1 map."""
    target = os.path.join(work, f"label{label}.nii.gz")
    nib.save(nib.Nifti1Image((aal == label).astype(np.uint8), aal_img.affine, aal_img.header), target)
    out = os.path.join(work, f"out{label}")
    cmd = [ffseg, "segment", target, "--target", "binary", "--sphere-from-label", f"{aal_path}:{label}",
           "--truth", aal_path, "--truth-labels", str(label), "--names", f"label{label}", "--out", out,
           "--force", "--quiet"]
    if resolution != "auto":
        cmd += ["--mesh-resolution", resolution]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"mesh_ceiling: {' '.join(cmd)} failed with exit {done.returncode}:\n{done.stderr}")
    with open(os.path.join(out, "report.json")) as f:
        report = json.load(f)
    obj = report["objects"][0]
    return obj["metrics"]["dice"], obj["metrics"]["assd_mm"], obj["volume_ml"], report["steps"]


def main():
    global aal_img
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ffseg", nargs="?", default="build/ffseg")
    ap.add_argument("--mesh-resolution", default="12")
    a = ap.parse_args()
    if not os.access(a.ffseg, os.X_OK):
        sys.exit(f"mesh_ceiling: {a.ffseg} is not an executable (make build first)")
    aal_path = os.path.join(MRI, "aal.nii.gz")
    aal_img = nib.load(aal_path)
    aal = np.asarray(aal_img.dataobj).astype(np.int32)
    print(f"| structure | AAL | Dice | ASSD mm | ml (label) | steps |   (mesh resolution {a.mesh_resolution})")
    print("|---|---|---|---|---|---|")
    dices, assds = [], []
    with tempfile.TemporaryDirectory(prefix="ffseg_mesh_ceiling_") as work:
        for label, name in STRUCTURES:
            d, s, ml, steps = run_one(a.ffseg, aal_path, aal, label, a.mesh_resolution, work)
            dices.append(d)
            assds.append(s)
            print(f"| {name} | {label} | {d:.3f} | {s:.2f} | {ml:.2f} ({np.count_nonzero(aal == label) / 1000:.2f}) | {steps} |",
                  flush=True)
    print(f"| mean | | {np.mean(dices):.3f} | {np.mean(assds):.2f} | | |")


if __name__ == "__main__":
    main()
