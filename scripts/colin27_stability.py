#!/usr/bin/python3
"""Seed stability on Colin27 through the ffseg tool (issue 19, stability).

For each AAL structure of the protocol, `ffseg segment` runs from six
spheres: the protocol sphere (--sphere-from-label) at 0.6x, 1x and 1.5x its
radius, and moved by 1 mm along world x, y and z. Printed per structure: each
seed's Dice against AAL and volume, and the lowest and mean Dice between the
six results (issue 19 asks every pair >= 0.85). With --consensus the results
compared are each run's consensus.nii.gz (ffseg segment --consensus: the
voxels inside the mesh in at least 5 of its own six runs), else labels.nii.gz
(the CLI's defaults).

  /usr/bin/python3 scripts/colin27_stability.py [FFSEG] [--consensus] [--labels 73,74]

Reads /usr/share/mricron/templates/ch2.nii.gz and aal.nii.gz (Debian
mricron-data); ffseg's outputs go to a temporary directory, removed at the
end. numpy and nibabel only.
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
    sys.exit("colin27_stability: needs python3-nibabel (make deps)")

from colin27_protocol import MRI, STRUCTURES  # noqa: E402 (scripts/colin27_protocol.py)
# (radius scale, shift mm): the seeds of issue 19's protocol.
SEEDS = [(0.6, (0, 0, 0)), (1, (0, 0, 0)), (1.5, (0, 0, 0)), (1, (1, 0, 0)), (1, (0, 1, 0)), (1, (0, 0, 1))]


def segment(ffseg, sphere_args, out, consensus):
    cmd = [ffseg, "segment", os.path.join(MRI, "ch2.nii.gz"), *sphere_args, "--out", out, "--force", "--quiet"]
    if consensus:
        cmd.append("--consensus")
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"colin27_stability: {' '.join(cmd)} failed with exit {done.returncode}:\n{done.stderr}")
    with open(os.path.join(out, "report.json")) as f:
        return json.load(f)


def dice(a, b):
    s = np.count_nonzero(a) + np.count_nonzero(b)
    return 1.0 if s == 0 else 2.0 * np.count_nonzero(a & b) / s


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ffseg", nargs="?", default="build/ffseg")
    ap.add_argument("--consensus", action="store_true")
    ap.add_argument("--labels", default=",".join(str(l) for l, _ in STRUCTURES))
    a = ap.parse_args()
    if not os.access(a.ffseg, os.X_OK):
        sys.exit(f"colin27_stability: {a.ffseg} is not an executable (make build first)")
    wanted = [int(x) for x in a.labels.split(",")]
    aal_path = os.path.join(MRI, "aal.nii.gz")
    aal = np.asarray(nib.load(aal_path).dataobj).astype(np.int32)
    result = "consensus.nii.gz" if a.consensus else "labels.nii.gz"
    print(f"| structure | Dice against AAL (ml): x0.6 / x1 / x1.5 / +x / +y / +z | pairwise Dice min / mean |   ({result})")
    print("|---|---|---|")
    mins, means = [], []
    with tempfile.TemporaryDirectory(prefix="ffseg_stability_") as work:
        for label, name in STRUCTURES:
            if label not in wanted:
                continue
            truth = aal == label
            rep = segment(a.ffseg, ["--sphere-from-label", f"{aal_path}:{label}"], os.path.join(work, "p"), False)
            c = rep["objects"][0]["sphere"]["center_mm"]
            r = rep["objects"][0]["sphere"]["radius_mm"]
            masks, cells = [], []
            for k, (scale, shift) in enumerate(SEEDS):
                sphere = ",".join(f"{v:.6f}" for v in (c[0] + shift[0], c[1] + shift[1], c[2] + shift[2], r * scale))
                out = os.path.join(work, f"s{k}")
                segment(a.ffseg, ["--sphere", sphere], out, a.consensus)
                m = np.asarray(nib.load(os.path.join(out, result)).dataobj) != 0
                masks.append(m)
                cells.append(f"{dice(m, truth):.3f} ({np.count_nonzero(m) / 1000:.1f})")
            pairs = [dice(masks[i], masks[j]) for i in range(6) for j in range(i + 1, 6)]
            mins.append(min(pairs))
            means.append(float(np.mean(pairs)))
            print(f"| {name} | {' / '.join(cells)} | {mins[-1]:.3f} / {means[-1]:.3f} |", flush=True)
    print(f"worst pair {min(mins):.3f}, mean of the structures' mean pairwise Dice {np.mean(means):.3f}, "
          f"structures with every pair >= 0.85: {sum(m >= 0.85 for m in mins)} of {len(mins)}")


if __name__ == "__main__":
    main()
