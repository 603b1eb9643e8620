#!/usr/bin/python3
"""How far can a grey-level interval go on Colin27? (issue 19, accuracy)

For each AAL structure of the protocol, the best Dice that any intensity
interval [lo, hi] reaches when an oracle also confines it to the label
dilated by k mm: Dice(T, {lo <= I <= hi} & dilate(T, k)), maximised over
every interval of the u8 grey levels. It bounds what a method that decides
voxels by their grey level alone can reach if its surface lands within k mm
of the truth: the neighbours inside that band share the structure's levels.

  /usr/bin/python3 scripts/intensity_ceiling.py [--bands 1,2,3]

Reads /usr/share/mricron/templates/ch2.nii.gz and aal.nii.gz (Debian
mricron-data; both on one 1 mm grid). numpy and nibabel only.
"""
import argparse
import sys

import numpy as np

try:
    import nibabel as nib
except ImportError:
    sys.exit("intensity_ceiling: needs python3-nibabel (make deps)")

from colin27_protocol import MRI, STRUCTURES  # noqa: E402 (scripts/colin27_protocol.py)


def dilate(mask, r):
    """mask dilated by a ball of radius r voxels (numpy shifts; r small)."""
    out = mask.copy()
    n = mask.shape
    for dz in range(-r, r + 1):
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                if dx * dx + dy * dy + dz * dz > r * r or (dx, dy, dz) == (0, 0, 0):
                    continue
                src = tuple(slice(max(0, -d), n[a] - max(0, d)) for a, d in enumerate((dx, dy, dz)))
                dst = tuple(slice(max(0, d), n[a] - max(0, -d)) for a, d in enumerate((dx, dy, dz)))
                out[dst] |= mask[src]
    return out


def best_interval(levels, truth, band):
    """Max over lo <= hi of Dice(truth, levels in [lo, hi] within truth | band)."""
    ht = np.bincount(levels[truth], minlength=256).astype(float)
    hb = np.bincount(levels[band], minlength=256).astype(float)
    ct = np.concatenate([[0.0], np.cumsum(ht)])
    cb = np.concatenate([[0.0], np.cumsum(hb)])
    lo = np.arange(256)[:, None]
    hi = np.arange(256)[None, :]
    tp = ct[hi + 1] - ct[lo]
    fp = cb[hi + 1] - cb[lo]
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(hi >= lo, 2 * tp / (truth.sum() + tp + fp), 0.0)
    i = np.unravel_index(np.nanargmax(d), d.shape)
    return float(d[i]), int(i[0]), int(i[1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bands", default="1,2,3", help="oracle bands in mm (voxels), comma-separated")
    args = ap.parse_args()
    t1 = nib.load(f"{MRI}/ch2.nii.gz")
    aal = nib.load(f"{MRI}/aal.nii.gz")
    if t1.shape != aal.shape or not np.allclose(t1.affine, aal.affine):
        sys.exit("intensity_ceiling: ch2 and aal are not on one grid")
    levels = np.clip(np.round(np.asarray(t1.dataobj, dtype=float)), 0, 255).astype(int)
    labels = np.asarray(aal.dataobj).astype(int)
    bands = [int(b) for b in args.bands.split(",")]
    print("| band (mm) | " + " | ".join(n for _, n in STRUCTURES) + " | mean |")
    print("|---" * (len(STRUCTURES) + 2) + "|")
    for k in bands:
        row = []
        for label, _ in STRUCTURES:
            truth = labels == label
            band = dilate(truth, k) & ~truth
            row.append(best_interval(levels, truth, band)[0])
        print(f"| {k} | " + " | ".join(f"{d:.3f}" for d in row) + f" | {np.mean(row):.3f} |")


if __name__ == "__main__":
    main()
