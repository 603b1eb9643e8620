#!/usr/bin/python3
"""Colin27 at 0.5 mm: the protocol run on a scan nothing was tuned on.

mricron-data ships, beside the 1 mm ch2.nii.gz that every Colin27 figure of
BENCHMARKS.md comes from, ch2better.nii.gz: the same head at 0.5 mm
(301 x 370 x 316, grey levels 0..130, another contrast and noise). No
parameter of ffseg was ever chosen on it, so it answers "does the result
hold on a scan you have not seen" for the same anatomy, where AAL still is
the truth.

For each structure: the protocol sphere (ffseg segment --sphere-from-label
on ch2, whose line on stderr gives centre and radius in world mm), the 1 mm
run with the CLI's defaults, then the same world sphere on ch2better with
the CLI's defaults. ch2better's voxel centres of even index coincide with
ch2's (x = -75 + 0.5 i against -90 + I), so its label map is read at AAL's
voxel centres, exactly: no interpolation. Printed per structure: Dice of
either run against AAL, Dice between the two runs, volumes in ml (1 mm grid).

usage: scripts/colin27_highres.py [FFSEG] [--labels 73,74,...]
Pure Python (no numpy): about 10 s per structure.
"""
import gzip
import os
import re
import struct
import subprocess
import sys
import tempfile

TEMPLATES = "/usr/share/mricron/templates"
PROTOCOL = [(73, "putamen L"), (74, "putamen R"), (77, "thalamus L"), (78, "thalamus R"),
            (71, "caudate L"), (72, "caudate R"), (37, "hippocampus L"), (38, "hippocampus R")]


def read_nifti_u8(path):
    """dims, (spacing, origin) per axis of an axis-aligned uint8 NIfTI-1, and its voxels."""
    raw = gzip.open(path).read()
    dims = struct.unpack("<8h", raw[40:56])[1:4]
    datatype = struct.unpack("<h", raw[70:72])[0]
    offset = int(struct.unpack("<f", raw[108:112])[0])
    if datatype != 2:
        sys.exit(f"{path}: datatype {datatype}, this script reads uint8 label maps only")
    rows = [struct.unpack("<4f", raw[280 + 16 * r:296 + 16 * r]) for r in range(3)]
    for r in range(3):
        if any(rows[r][c] != 0 for c in range(3) if c != r):
            sys.exit(f"{path}: the affine is not axis-aligned")
    axes = [(rows[r][r], rows[r][3]) for r in range(3)]
    return dims, axes, raw[offset:offset + dims[0] * dims[1] * dims[2]]


def on_grid(fine, grid):
    """The fine map's voxel at each grid voxel centre (which must coincide with one)."""
    (fx, fy, fz), faxes, fdata = fine
    (gx, gy, gz), gaxes, _ = grid
    idx = []
    for a, (n, fn) in enumerate(zip((gx, gy, gz), (fx, fy, fz))):
        g_step, g_org = gaxes[a]
        f_step, f_org = faxes[a]
        col = []
        for i in range(n):
            f = (g_org + g_step * i - f_org) / f_step
            if abs(f - round(f)) > 1e-3:
                sys.exit("the grids' voxel centres do not coincide")
            col.append(int(round(f)) if 0 <= round(f) < fn else -1)
        idx.append(col)
    out = bytearray(gx * gy * gz)
    for k in range(gz):
        fk = idx[2][k]
        if fk < 0:
            continue
        for j in range(gy):
            fj = idx[1][j]
            if fj < 0:
                continue
            row = (fk * fy + fj) * fx
            base = (k * gy + j) * gx
            out[base:base + gx] = bytes(fdata[row + fi] if fi >= 0 else 0 for fi in idx[0])
    return bytes(out)


def dice(a, la, b, lb):
    # bytes.translate maps each voxel to 1 / 0 at C speed; counting the 1s then is cheap.
    ta = bytes(1 if v == la else 0 for v in range(256))
    tb = bytes(2 if v == lb else 0 for v in range(256))
    ma, mb = a.translate(ta), b.translate(tb)
    na, nb = ma.count(1), mb.count(2)
    both = bytes(x + y for x, y in zip(ma, mb)).count(3) if na and nb else 0
    return (2 * both / (na + nb) if na + nb else 1.0), na, nb


def segment(ffseg, volume, sphere_args, out):
    run = subprocess.run([ffseg, "segment", volume, *sphere_args, "--out", out, "--quiet"],
                         capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"ffseg segment {volume} failed ({run.returncode}):\n{run.stderr}")
    return run.stdout + run.stderr


def main():
    args = sys.argv[1:]
    labels = None
    if "--labels" in args:
        at = args.index("--labels")
        labels = [int(x) for x in args[at + 1].split(",")]
        del args[at:at + 2]
    ffseg = args[0] if args else "build/ffseg"
    chosen = [(l, n) for l, n in PROTOCOL if labels is None or l in labels]
    aal_path = os.path.join(TEMPLATES, "aal.nii.gz")
    ch2, fine = os.path.join(TEMPLATES, "ch2.nii.gz"), os.path.join(TEMPLATES, "ch2better.nii.gz")
    aal = read_nifti_u8(aal_path)
    print("| structure | AAL | sphere (mm) | Dice 1 mm | Dice 0.5 mm | 1 mm vs 0.5 mm | ml 1 mm / 0.5 mm / AAL |")
    print("|---|---|---|---|---|---|---|")
    sums = [0.0, 0.0, 0.0]
    with tempfile.TemporaryDirectory() as tmp:
        for label, name in chosen:
            a_dir, b_dir = os.path.join(tmp, f"a{label}"), os.path.join(tmp, f"b{label}")
            # --quiet drops the sphere line too, so the 1 mm run prints it on its own first.
            probe = subprocess.run([ffseg, "segment", ch2, "--sphere-from-label", f"{aal_path}:{label}",
                                    "--max-steps", "1", "--out", os.path.join(tmp, "probe"), "--force"],
                                   capture_output=True, text=True)
            m = re.search(r"centre \(([-\d.e]+), ([-\d.e]+), ([-\d.e]+)\) mm, radius ([\d.e]+) mm", probe.stderr)
            if not m:
                sys.exit(f"no sphere line for label {label}:\n{probe.stderr}")
            sphere = ",".join(m.groups())
            segment(ffseg, ch2, ["--sphere", sphere], a_dir)
            segment(ffseg, fine, ["--sphere", sphere], b_dir)
            coarse = read_nifti_u8(os.path.join(a_dir, "labels.nii.gz"))[2]
            fine_on_aal = on_grid(read_nifti_u8(os.path.join(b_dir, "labels.nii.gz")), aal)
            d1, n1, nt = dice(coarse, 1, aal[2], label)
            d2, n2, _ = dice(fine_on_aal, 1, aal[2], label)
            d12, _, _ = dice(coarse, 1, fine_on_aal, 1)
            for s, d in enumerate((d1, d2, d12)):
                sums[s] += d
            print(f"| {name} | {label} | {sphere} | {d1:.3f} | {d2:.3f} | {d12:.3f} | "
                  f"{n1 / 1000:.1f} / {n2 / 1000:.1f} / {nt / 1000:.1f} |", flush=True)
    k = len(chosen)
    print(f"| mean | | | {sums[0] / k:.3f} | {sums[1] / k:.3f} | {sums[2] / k:.3f} | |")


if __name__ == "__main__":
    main()
