"""DICOM objects out of `ffseg segment`, read back with pydicom: the DICOM
Segmentation's frames equal labels.* voxel for voxel; every RT Structure Set
contour lies on its slice's plane, the pixel centres inside a slice's contours
are exactly the label map's voxels of that slice, and the contour points lie
within half a voxel of those voxels' boundary (all but 1%: thinner-than-a-voxel
features of the mesh reach up to a voxel beyond); both objects reference the
source series (or, for NIfTI input, a generated study and no image), and
dciodvfy (Debian dicom3tools) reports no error on either."""
import json
import os
import random
import shutil
import subprocess

import numpy as np
import pytest

import imagefiles as F
from conftest import MRI, ball, need_mricron, run_cli

SEG_STORAGE = "1.2.840.10008.5.1.4.1.1.66.4"
RTSTRUCT_STORAGE = "1.2.840.10008.5.1.4.1.1.481.3"


def read_series(directory):
    """The series' slices sorted along the normal: (datasets, normal)."""
    import pydicom
    ds = [pydicom.dcmread(os.path.join(directory, n)) for n in sorted(os.listdir(directory))]
    iop = np.array(ds[0].ImageOrientationPatient, float)
    normal = np.cross(iop[:3], iop[3:])
    ds.sort(key=lambda d: float(np.dot(np.array(d.ImagePositionPatient, float), normal)))
    return ds, normal


def rotated_affine():
    """An oblique grid (20 degrees about z, 10 about x), anisotropic voxels."""
    a, b = np.radians(20), np.radians(10)
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    A = np.eye(4)
    A[:3, :3] = rz @ rx @ np.diag([0.9, 0.8, 1.5])
    A[:3, 3] = [-30.0, 12.0, -8.0]
    return A


def geometry(A):
    """LPS row / column directions, spacings and the slice normal of a RAS affine."""
    M = F.LPS @ A[:3, :3]
    sp = np.linalg.norm(M, axis=0)
    return M, sp


def seg_volumes(seg, shape, origin_lps, M):
    """{segment number: mask[i, j, k]} rebuilt from the frames by their positions."""
    frames = seg.pixel_array.reshape(-1, shape[1], shape[0])  # frame, row (j), column (i)
    inv = np.linalg.inv(M)
    out = {int(s.SegmentNumber): np.zeros(shape, bool) for s in seg.SegmentSequence}
    for f, item in enumerate(seg.PerFrameFunctionalGroupsSequence):
        number = int(item.SegmentIdentificationSequence[0].ReferencedSegmentNumber)
        pos = np.array(item.PlanePositionSequence[0].ImagePositionPatient, float)
        ijk = inv @ (pos - origin_lps)
        k = int(round(ijk[2]))
        assert np.allclose(ijk, [0, 0, k], atol=1e-3), "a frame's position is not a slice of the grid"
        out[number][:, :, k] |= frames[f].T.astype(bool)
    return out


def check_seg(path, labels, A, names, label_of):
    import pydicom
    seg = pydicom.dcmread(path)
    assert seg.SOPClassUID == SEG_STORAGE and seg.Modality == "SEG"
    assert seg.SegmentationType == "BINARY"
    M, _ = geometry(A)
    origin = F.LPS @ A[:3, 3]
    vols = seg_volumes(seg, labels.shape, origin, M)
    assert [s.SegmentLabel for s in seg.SegmentSequence] == names
    for s in seg.SegmentSequence:
        label = label_of[s.SegmentLabel]
        assert s.SegmentDescription == f"label {label}"
        assert len(s.RecommendedDisplayCIELabValue) == 3
        want = labels == label
        assert want.sum() > 0
        assert np.array_equal(vols[int(s.SegmentNumber)], want), f"segment {s.SegmentLabel} differs from labels"
    return seg


def segment_to_inside(poly_ij, shape_ij):
    """Pixel centres inside the closed polygons (even-odd rule), mask[i, j]."""
    ii, jj = np.meshgrid(np.arange(shape_ij[0]), np.arange(shape_ij[1]), indexing="ij")
    inside = np.zeros(shape_ij, bool)
    for poly in poly_ij:
        x, y = poly[:, 0], poly[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        crossing = np.zeros(shape_ij, bool)
        for a, b, c, d in zip(x, y, xn, yn):
            if b == d:
                continue
            hit = ((b > jj) != (d > jj))
            xs = a + (jj - b) * (c - a) / (d - b)
            crossing ^= hit & (ii < xs)
        inside ^= crossing
    return inside


def boundary_distance(points_ij, mask, sp):
    """Distance (mm) of each point to the rasterised boundary: the edges
    between inside and outside pixels, each pixel the square around its
    centre (inf where no such edge is within two pixels)."""
    out = []
    for p in points_ij:
        i0, j0 = int(np.floor(p[0])), int(np.floor(p[1]))
        best = np.inf
        for a in range(i0 - 2, i0 + 3):
            for b in range(j0 - 2, j0 + 3):
                here = bool(mask[a, b]) if 0 <= a < mask.shape[0] and 0 <= b < mask.shape[1] else False
                for da, db in ((1, 0), (0, 1)):
                    a2, b2 = a + da, b + db
                    there = bool(mask[a2, b2]) if 0 <= a2 < mask.shape[0] and 0 <= b2 < mask.shape[1] else False
                    if here == there:
                        continue
                    # The shared side of the two squares.
                    mid = np.array([a + da / 2, b + db / 2])
                    half = np.array([db / 2, da / 2])
                    e0, e1 = (mid - half) * sp, (mid + half) * sp
                    q = p * sp
                    t = np.clip(np.dot(q - e0, e1 - e0) / np.dot(e1 - e0, e1 - e0), 0, 1)
                    best = min(best, float(np.linalg.norm(q - (e0 + t * (e1 - e0)))))
        out.append(best)
    return np.array(out)


def check_rtstruct(path, labels, A, names, label_of, image_uids=None):
    """Every contour on its slice's plane, within half a voxel of the label
    map's boundary in that slice; the pixel centres inside the contours are
    the label's voxels. Returns the datasets and the figures measured."""
    import pydicom
    rt = pydicom.dcmread(path)
    assert rt.SOPClassUID == RTSTRUCT_STORAGE and rt.Modality == "RTSTRUCT"
    M, sp = geometry(A)
    inv = np.linalg.inv(M)
    origin = F.LPS @ A[:3, 3]
    normal = np.cross(M[:, 0], M[:, 1])
    normal /= np.linalg.norm(normal)
    rois = {int(r.ROINumber): r.ROIName for r in rt.StructureSetROISequence}
    assert sorted(rois.values()) == sorted(names)
    worst, total, several, tiny, far_points = 0.0, 0, 0, 0, 0
    for rc in rt.ROIContourSequence:
        name = rois[int(rc.ReferencedROINumber)]
        label = label_of[name]
        assert int(rc.ReferencedROINumber) == label
        mask = labels == label
        per_slice = {}
        for c in rc.ContourSequence:
            assert c.ContourGeometricType == "CLOSED_PLANAR"
            pts = np.array(c.ContourData, float).reshape(-1, 3)
            assert len(pts) == int(c.NumberOfContourPoints) >= 3
            ijk = (inv @ (pts - origin).T).T
            k = int(round(ijk[0, 2]))
            # On the plane through slice k's voxel centres, to 1e-3 mm.
            assert np.max(np.abs((pts - (origin + M[:, 2] * k)) @ normal)) < 1e-3
            if image_uids is not None:
                assert c.ContourImageSequence[0].ReferencedSOPInstanceUID == image_uids[k]
            d = boundary_distance(ijk[:, :2], mask[:, :, k], sp[:2])
            if np.isinf(d).all():
                # A cut too small to hold a voxel centre (near a pole of the
                # mesh): no voxel boundary to compare with; it must hold no
                # voxel (checked below) and span less than two voxels.
                span = (ijk[:, :2].max(axis=0) - ijk[:, :2].min(axis=0)) * sp[:2]
                assert np.all(span < 2 * sp[:2]), f"{name}: a contour of {span} mm holds no voxel"
                tiny += 1
                d = np.zeros(1)
            worst = max(worst, float(d.max()))
            far_points += int((d > 0.5 * max(sp[0], sp[1])).sum())
            total += len(pts)
            per_slice.setdefault(k, []).append(ijk[:, :2])
        for k in range(mask.shape[2]):
            polys = per_slice.get(k, [])
            several += len(polys) > 1
            inside = segment_to_inside(polys, mask.shape[:2]) if polys else np.zeros(mask.shape[:2], bool)
            assert np.array_equal(inside, mask[:, :, k]), f"{name}: slice {k}'s contours do not hold its voxels"
    # Half a voxel: half the pixel's diagonal, the farthest a point of a
    # pixel's square is from its centre.
    # Half a voxel (the largest in-plane spacing) for all but 1% of the
    # points, one voxel for every point: where the mesh has a feature thinner
    # than a voxel that no voxel centre falls in (the equality above holds
    # there too), its contour reaches up to a voxel beyond the voxels'
    # boundary; that is the detail the contours add.
    half = 0.5 * max(sp[0], sp[1])
    assert far_points <= 0.01 * total, f"{far_points} of {total} contour points beyond half a voxel"
    assert worst <= 2 * half, f"a contour point is {worst:.3f} mm from the voxel boundary"
    print(f"{path}: {tiny} contours hold no voxel centre; {far_points} of {total} points beyond half the "
          f"largest spacing, the farthest {worst:.3f} mm")
    return rt, worst, total, several


def dciodvfy_errors(path):
    r = subprocess.run(["dciodvfy", path], capture_output=True, text=True)
    return [l for l in (r.stdout + r.stderr).splitlines() if l.startswith("Error")]


def need_dicom3tools():
    if not shutil.which("dciodvfy"):
        pytest.skip("dciodvfy (Debian dicom3tools) is not installed: `make deps`")


@pytest.fixture(scope="module")
def series(tmp_path_factory):
    """Two separate bodies on an oblique anisotropic grid as a DICOM series
    (file names out of position order): a ball, and a dumbbell whose two
    lobes are separate contours in some slices."""
    d = tmp_path_factory.mktemp("series")
    shape = (48, 44, 30)
    vol = ball(shape, centre=(14.0, 20.0, 14.0), radius=7.0, dtype=np.int16, inside=300, outside=0)
    i, j, k = np.meshgrid(*[np.arange(n, dtype=float) for n in shape], indexing="ij")
    lobes = ((i - 34) ** 2 + (j - 12) ** 2 + (k - 12) ** 2 <= 36) | ((i - 34) ** 2 + (j - 30) ** 2 + (k - 12) ** 2 <= 36)
    neck = (np.abs(i - 34) <= 2.5) & (j >= 12) & (j <= 30) & (np.abs(k - 12) <= 1.5)
    vol[lobes | neck] = 300
    A = rotated_affine()
    order = list(range(shape[2]))
    random.Random(3).shuffle(order)
    F.write_dicom_series(str(d / "s"), vol, A, order=order)
    binary = (vol > 0).astype(np.uint8)
    import nibabel
    nibabel.save(nibabel.Nifti1Image(binary, A), str(d / "binary.nii.gz"))
    return d, A, shape


def test_seg_and_rtstruct_from_a_dicom_series(series, tmp_path):
    need_dicom3tools()
    d, A, shape = series
    c_ball = A @ [14, 20, 14, 1]
    c_bell = A @ [34, 12, 12, 1]
    out = tmp_path / "out"
    run_cli("segment", d / "s", "--target", "binary", "--sphere", ",".join(f"{v:.4f}" for v in c_ball[:3]) + ",4",
            "--sphere", ",".join(f"{v:.4f}" for v in c_bell[:3]) + ",3", "--names", "ball,bell",
            "--rtstruct", tmp_path / "rt.dcm", "--out", out, "-q")
    rep = json.loads((out / "report.json").read_text())
    outs = rep["outputs"]
    assert outs["dicom_seg"] == "segmentation.dcm" and outs["dicom_references"] == "source series"
    assert outs["rtstruct"] == str(tmp_path / "rt.dcm") and outs["rtstruct_contours"] > 0
    import nibabel
    im = nibabel.load(str(out / "labels.nii.gz"))
    labels = np.asarray(im.dataobj)
    assert np.allclose(im.affine, A, atol=1e-4)
    label_of = {"ball": 1, "bell": 2}
    src, _ = read_series(str(d / "s"))
    uids = [s.SOPInstanceUID for s in src]

    seg = check_seg(str(out / "segmentation.dcm"), labels, A, ["ball", "bell"], label_of)
    assert seg.StudyInstanceUID == src[0].StudyInstanceUID
    assert seg.FrameOfReferenceUID == src[0].FrameOfReferenceUID
    assert seg.PatientID == src[0].PatientID and seg.SeriesInstanceUID != src[0].SeriesInstanceUID
    ref = seg.ReferencedSeriesSequence[0]
    assert ref.SeriesInstanceUID == src[0].SeriesInstanceUID
    assert sorted(x.ReferencedSOPInstanceUID for x in ref.ReferencedInstanceSequence) == sorted(uids)
    M, _ = geometry(A)
    origin = F.LPS @ A[:3, 3]
    for item in seg.PerFrameFunctionalGroupsSequence:
        pos = np.array(item.PlanePositionSequence[0].ImagePositionPatient, float)
        k = int(round((np.linalg.inv(M) @ (pos - origin))[2]))
        source = item.DerivationImageSequence[0].SourceImageSequence[0]
        assert source.ReferencedSOPInstanceUID == uids[k]

    rt, worst, points, several = check_rtstruct(str(tmp_path / "rt.dcm"), labels, A, ["ball", "bell"], label_of, uids)
    assert rt.StudyInstanceUID == src[0].StudyInstanceUID and rt.PatientID == src[0].PatientID
    fr = rt.ReferencedFrameOfReferenceSequence[0]
    assert fr.FrameOfReferenceUID == src[0].FrameOfReferenceUID
    series_ref = fr.RTReferencedStudySequence[0].RTReferencedSeriesSequence[0]
    assert series_ref.SeriesInstanceUID == src[0].SeriesInstanceUID
    assert sorted(x.ReferencedSOPInstanceUID for x in series_ref.ContourImageSequence) == sorted(uids)
    assert several > 0, "the dumbbell's lobes never gave two contours in one slice"
    print(f"rtstruct: {points} points, farthest {worst:.3f} mm from the voxel boundary, "
          f"{several} slices with several contours")
    for p in (out / "segmentation.dcm", tmp_path / "rt.dcm"):
        assert dciodvfy_errors(str(p)) == [], p


def test_dicom_objects_from_nifti_colin27_have_a_generated_study(tmp_path):
    need_mricron()
    need_dicom3tools()
    out = tmp_path / "out"
    r = run_cli("segment", f"{MRI}/ch2.nii.gz", "--sphere-from-label", f"{MRI}/aal.nii.gz:73",
                "--sphere-from-label", f"{MRI}/aal.nii.gz:77", "--names", "putamen_L,thalamus_L",
                "--dicom-seg", tmp_path / "seg.dcm", "--rtstruct", tmp_path / "rt.dcm", "--out", out)
    assert "reference" in r.stderr and "not a DICOM series" in r.stderr
    assert not (out / "segmentation.dcm").exists()
    rep = json.loads((out / "report.json").read_text())
    assert rep["outputs"]["dicom_references"] == "generated study"
    assert "no source image referenced" in rep["outputs"]["dicom_note"]
    import nibabel
    im = nibabel.load(str(out / "labels.nii.gz"))
    labels, A = np.asarray(im.dataobj), im.affine
    label_of = {"putamen_L": 73, "thalamus_L": 77}
    seg = check_seg(str(tmp_path / "seg.dcm"), labels, A, ["putamen_L", "thalamus_L"], label_of)
    rt, worst, points, _ = check_rtstruct(str(tmp_path / "rt.dcm"), labels, A, ["putamen_L", "thalamus_L"], label_of)
    print(f"Colin27 rtstruct: {points} points, farthest {worst:.3f} mm from the voxel boundary")
    # One generated study and frame of reference for both objects, no image referenced.
    assert seg.StudyInstanceUID == rt.StudyInstanceUID and seg.FrameOfReferenceUID == rt.FrameOfReferenceUID
    assert rt.ReferencedFrameOfReferenceSequence[0].FrameOfReferenceUID == seg.FrameOfReferenceUID
    assert "ReferencedSeriesSequence" not in seg and "DerivationImageSequence" not in \
        seg.PerFrameFunctionalGroupsSequence[0]
    assert "RTReferencedStudySequence" not in rt.ReferencedFrameOfReferenceSequence[0]
    assert all("ContourImageSequence" not in c for rc in rt.ROIContourSequence for c in rc.ContourSequence)
    assert seg.PatientID == rt.PatientID == "FFSEG-GENERATED"
    for p in (tmp_path / "seg.dcm", tmp_path / "rt.dcm"):
        assert dciodvfy_errors(str(p)) == [], p


def test_dicom_output_paths_are_checked_first(tmp_path):
    need_mricron()
    (tmp_path / "there.dcm").write_bytes(b"x")
    cases = [(["--dicom-seg", tmp_path / "there.dcm"], "exists"),
             (["--rtstruct", tmp_path / "x.nii"], "must end in .dcm"),
             (["--rtstruct", tmp_path / "no" / "x.dcm"], "does not exist"),
             (["--dicom-seg", tmp_path / "a.dcm", "--rtstruct", tmp_path / "a.dcm"], "both written to"),
             (["--view", "sideways"], "expected radiological or neurological")]
    for extra, message in cases:
        r = run_cli("segment", f"{MRI}/ch2.nii.gz", "--sphere", "0,0,0,5", "--out", tmp_path / "o", *extra, check=False)
        assert r.returncode == 2 and message in r.stderr, (extra, r.stderr)
        assert not (tmp_path / "o").exists()


def test_a_series_without_frame_of_reference_gets_a_new_one_and_a_note(tmp_path):
    need_dicom3tools()
    import pydicom
    vol = ball((24, 22, 12), centre=(11.0, 10.0, 6.0), radius=4.0, dtype=np.int16, inside=300)
    A = np.diag([1.0, 1.0, 2.0, 1.0])
    F.write_dicom_series(str(tmp_path / "s"), vol, A, with_frame_of_reference=False)
    out = tmp_path / "out"
    r = run_cli("segment", tmp_path / "s", "--target", "binary", "--sphere", "11,10,12,2", "--out", out)
    assert "without FrameOfReferenceUID" in r.stderr
    assert "new frame of reference" in json.loads((out / "report.json").read_text())["outputs"]["dicom_note"]
    seg = pydicom.dcmread(str(out / "segmentation.dcm"))
    src = pydicom.dcmread(str(tmp_path / "s" / "IM0000.dcm"))
    assert "FrameOfReferenceUID" not in src and seg.FrameOfReferenceUID
    assert seg.StudyInstanceUID == src.StudyInstanceUID
    assert dciodvfy_errors(str(out / "segmentation.dcm")) == []
