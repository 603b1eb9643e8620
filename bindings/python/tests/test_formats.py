"""NRRD, MetaImage and DICOM input through the `ffseg` tool: the same Colin27
segmentation from every format (mask voxel for voxel, mesh in the same world
coordinates), label maps written in the input's family, and strict headers
(exit 3, a message naming the field)."""
import gzip
import json
import os
import random
import re

import numpy as np
import pytest

import imagefiles as F
from conftest import MRI, affine, ball, need_mricron, run_cli
from test_colin27 import read_ply


def read_labels(path):
    if path.endswith(".nrrd"):
        return F.read_nrrd(path)
    if path.endswith(".mha"):
        return F.read_mha(path)
    import nibabel
    im = nibabel.load(path)
    return np.asarray(im.dataobj), im.affine


@pytest.fixture(scope="module")
def colin27(tmp_path_factory):
    need_mricron()
    import nibabel
    d = tmp_path_factory.mktemp("colin27")
    im = nibabel.load(f"{MRI}/ch2.nii.gz")
    vol, A = np.asarray(im.dataobj.get_unscaled()), im.affine
    assert vol.dtype == np.uint8
    F.write_nrrd(str(d / "ch2.nrrd"), vol, A)
    F.write_nhdr(str(d / "ch2.nhdr"), vol, A)
    F.write_mha(str(d / "ch2.mha"), vol, A)
    F.write_mhd(str(d / "ch2.mhd"), vol, A)
    order = list(range(vol.shape[2]))
    random.Random(5).shuffle(order)  # file names out of position order
    F.write_dicom_series(str(d / "ch2_dicom"), vol, A, order=order)
    return d, vol, A


INPUTS = [("ch2.nrrd", "labels.nrrd"), ("ch2.nhdr", "labels.nrrd"), ("ch2.mha", "labels.mha"),
          ("ch2.mhd", "labels.mha"), ("ch2_dicom", "labels.nii.gz")]


def segment(src, out):
    run_cli("segment", src, "--sphere-from-label", f"{MRI}/aal.nii.gz:73", "--mesh-resolution", "12",
            "--names", "putamen_L", "--out", out, "-q")
    return json.loads(open(os.path.join(out, "report.json")).read())


def test_colin27_gives_the_same_mask_and_mesh_from_every_format(colin27, tmp_path):
    d, vol, A = colin27
    ref_report = segment(f"{MRI}/ch2.nii.gz", str(tmp_path / "nii"))
    ref_labels, _ = read_labels(str(tmp_path / "nii" / "labels.nii.gz"))
    ref_xyz, ref_tris = read_ply(tmp_path / "nii" / "putamen_L.ply")
    assert ref_report["objects"][0]["voxels"] > 1000
    for name, labels_name in INPUTS:
        out = str(tmp_path / name.replace(".", "_"))
        rep = segment(str(d / name), out)
        fmt = {"nrrd": "nrrd", "nhdr": "nrrd", "mha": "metaimage", "mhd": "metaimage"}.get(
            name.split(".")[-1], "dicom")
        assert rep["input"]["format"] == fmt
        assert rep["outputs"]["labels"] == labels_name
        np.testing.assert_allclose(rep["input"]["index_to_world"], ref_report["input"]["index_to_world"],
                                   rtol=0, atol=1e-9, err_msg=name)
        labels, LA = read_labels(os.path.join(out, labels_name))
        assert labels.shape == ref_labels.shape
        assert int((labels != ref_labels).sum()) == 0, name
        np.testing.assert_allclose(LA, A, rtol=0, atol=1e-9, err_msg=name)  # written in the same frame
        xyz, tris = read_ply(os.path.join(out, "putamen_L.ply"))
        assert np.array_equal(tris, ref_tris)
        assert np.abs(xyz - ref_xyz).max() <= 1e-4, name
        assert rep["steps"] == ref_report["steps"]


def test_labels_format_option_chooses_the_family(colin27, tmp_path):
    d, vol, A = colin27
    small = vol[60:120, 80:150, 40:100]
    B = A.copy()
    B[:3, 3] = (A @ np.array([60, 80, 40, 1.0]))[:3]
    src = str(tmp_path / "crop.nrrd")
    F.write_nrrd(src, np.ascontiguousarray(small), B)
    first = None
    for opt, name in (("nrrd", "labels.nrrd"), ("nifti", "labels.nii.gz"), ("metaimage", "labels.mha")):
        out = str(tmp_path / opt)
        run_cli("segment", src, "--sphere", "-20,14,-4,3", "--mesh-resolution", "8", "--max-steps", "5",
                "--labels-format", opt, "--out", out, "-q")
        labels, LA = read_labels(os.path.join(out, name))
        assert labels.shape == small.shape and labels.max() == 1
        np.testing.assert_allclose(LA, B, atol=1e-9)
        if first is None:
            first = labels
        assert np.array_equal(labels, first)
        # ffseg reads its own label maps back, on the same grid.
        r = run_cli("eval", os.path.join(out, name), str(tmp_path / "nrrd" / "labels.nrrd"), "--json")
        assert json.loads(r.stdout)["labels"][0]["dice"] == 1.0
    r = run_cli("segment", src, "--sphere", "-20,14,-4,3", "--labels-format", "dicom", "--out",
                str(tmp_path / "x"), check=False)
    assert r.returncode == 2 and "--labels-format" in r.stderr


def small_volume(dtype=np.int16):
    return ball(shape=(24, 20, 16), centre=(11.0, 9.5, 7.5), radius=5.0, inside=300, outside=0, dtype=dtype)


def test_geometry_and_types_from_each_format(tmp_path):
    A = np.array([[0.0, -1.2, 0.0, 30.0], [0.9, 0.0, 0.0, -12.5], [0.0, 0.0, 2.0, 7.25], [0, 0, 0, 1]])
    for dt in (np.uint8, np.int16, np.uint16, np.int32, np.float32, np.float64):
        vol = small_volume(dt)
        files = {"a.nrrd": F.write_nrrd, "b.mha": F.write_mha, "c.nhdr": F.write_nhdr, "d.mhd": F.write_mhd,
                 "e.nhdr": lambda p, v, A: F.write_nhdr(p, v, A, "gzip"),
                 "f.nrrd": lambda p, v, A: F.write_nrrd(p, v, A, "raw"),
                 "g.mha": lambda p, v, A: F.write_mha(p, v, A, compressed=False)}
        for name, writer in files.items():
            p = str(tmp_path / f"{dt.__name__}_{name}")
            writer(p, vol, A)
            r = run_cli("info", p)
            assert "dims:         24 x 20 x 16" in r.stdout, (name, r.stdout)
            assert "non-zero:     %d voxels" % int((vol != 0).sum()) in r.stdout, name
            rows = [l for l in r.stdout.splitlines() if l.strip().startswith("[")]
            got = np.array([[float(x) for x in l.strip()[1:-1].split()] for l in rows])
            np.testing.assert_allclose(got, A, atol=1e-4, err_msg=name)
    # Big-endian NRRD reads the same voxels.
    vol = small_volume(np.int16)
    F.write_nrrd(str(tmp_path / "le.nrrd"), vol, A)
    F.write_nrrd(str(tmp_path / "be.nrrd"), vol, A, big_endian=True)
    out = [run_cli("info", str(tmp_path / n)).stdout.split("\n", 1)[1] for n in ("le.nrrd", "be.nrrd")]
    assert out[0] == out[1]


def test_dicom_sorting_spacing_and_rescale(tmp_path):
    vol = small_volume(np.int16)
    A = affine((0.8, 0.8, 2.5), (-10.0, 5.0, 30.0))
    # Stored = (value + 1000) / 2, slope 2, intercept -1000; names in reverse order, SliceThickness wrong.
    stored = ((vol.astype(np.int32) + 1000) // 2).astype(np.int16)
    F.write_dicom_series(str(tmp_path / "s"), vol, A, slope=2, intercept=-1000, stored=stored,
                         order=list(range(vol.shape[2]))[::-1], slice_thickness=9.0)
    r = run_cli("info", str(tmp_path / "s"))
    assert "format:       dicom" in r.stdout
    assert "scaling:      value = 2 * stored + -1000" in r.stdout
    assert "spacing:      0.8 x 0.8 x 2.5 mm" in r.stdout
    assert "intensity:    0 .. 300" in r.stdout
    assert "non-zero:     %d voxels" % int((vol != 0).sum()) in r.stdout
    # The binary segmentation of the ball is the NIfTI one's (slope 2, stored = value / 2;
    # the binary target reads stored values, so the intercept stays 0 here).
    import nibabel
    F.write_dicom_series(str(tmp_path / "h"), vol, A, slope=2, stored=(vol // 2).astype(np.int16),
                         order=list(range(vol.shape[2]))[::-1], slice_thickness=9.0)
    nibabel.save(nibabel.Nifti1Image(vol, A), str(tmp_path / "v.nii.gz"))
    outs = []
    for src in ("v.nii.gz", "h"):
        o = str(tmp_path / ("out_" + src.replace(".", "_")))
        run_cli("segment", str(tmp_path / src), "--target", "binary", "--sphere", "%g,%g,%g,2" % tuple(
            (A @ np.array([11, 9.5, 7.5, 1]))[:3]), "--mesh-resolution", "8", "--out", o, "-q")
        outs.append(np.asarray(nibabel.load(os.path.join(o, "labels.nii.gz")).dataobj))
    assert 300 < outs[0].sum() < 600 and np.array_equal(outs[0], outs[1])


def test_dicom_series_errors(tmp_path):
    vol = small_volume(np.int16)
    A = affine((1.0, 1.0, 2.0))
    F.write_dicom_series(str(tmp_path / "gap"), vol, A)
    os.remove(str(tmp_path / "gap" / "IM0005.dcm"))
    r = run_cli("info", str(tmp_path / "gap"), check=False)
    assert r.returncode == 3 and "evenly spaced" in r.stderr and "ImagePositionPatient" in r.stderr
    F.write_dicom_series(str(tmp_path / "two"), vol[:, :, :4], A)
    F.write_dicom_series(str(tmp_path / "other"), vol[:, :, 4:8], A)
    os.rename(str(tmp_path / "other" / "IM0000.dcm"), str(tmp_path / "two" / "IM9999.dcm"))
    r = run_cli("info", str(tmp_path / "two"), check=False)
    assert r.returncode == 3 and "SeriesInstanceUID" in r.stderr
    os.makedirs(str(tmp_path / "junk"))
    F.write_dicom_series(str(tmp_path / "junk"), vol[:, :, :3], A)
    open(str(tmp_path / "junk" / "notes.txt"), "w").write("not an image\n")
    r = run_cli("info", str(tmp_path / "junk"), check=False)
    assert r.returncode == 3 and "notes.txt" in r.stderr and "GDCM" in r.stderr
    os.makedirs(str(tmp_path / "empty"))
    r = run_cli("info", str(tmp_path / "empty"), check=False)
    assert r.returncode == 3 and "no file" in r.stderr


# Each case: (description, header edit, words the message must contain).
NRRD_CASES = [
    ("bad magic", lambda h: h.replace("NRRD0004", "NRRD0009"), ["NRRD0001"]),
    ("type", lambda h: h.replace("type: int16", "type: complex"), ["'type'", "complex"]),
    ("block", lambda h: h.replace("type: int16", "type: block"), ["'type'", "block"]),
    ("dimension", lambda h: h.replace("dimension: 3", "dimension: 4"), ["'dimension'"]),
    ("sizes", lambda h: h.replace("sizes: 24 20 16", "sizes: 24 20"), ["'sizes'"]),
    ("sizes zero", lambda h: h.replace("sizes: 24 20 16", "sizes: 24 0 16"), ["'sizes'"]),
    ("encoding", lambda h: h.replace("encoding: gzip", "encoding: bzip2"), ["'encoding'", "bzip2"]),
    ("endian", lambda h: h.replace("endian: little", "endian: middle"), ["'endian'"]),
    ("no endian", lambda h: h.replace("endian: little\n", ""), ["'endian'", "missing"]),
    ("space", lambda h: h.replace("space: left-posterior-superior", "space: scanner-xyz"), ["'space'"]),
    ("directions", lambda h: h.replace("space directions: (", "space directions: ((", 1), ["'space directions'"]),
    ("directions nan", lambda h: h.replace("space directions: (-1.0", "space directions: (nan"),
     ["'space directions'"]),
    ("singular", lambda h: h.replace("(0.0,0.0,1.0)", "(0.0,-1.0,0.0)"), ["'space directions'", "singular"]),
    ("origin", lambda h: h.replace("space origin: (", "space origin: (1,"), ["'space origin'"]),
    ("kinds", lambda h: h.replace("kinds: domain domain domain", "kinds: domain domain RGB-color"), ["'kinds'"]),
    ("unknown field", lambda h: h.replace("kinds:", "colour: red\nkinds:"), ["'colour'"]),
    ("twice", lambda h: h.replace("kinds:", "dimension: 3\nkinds:"), ["'dimension'", "twice"]),
    ("data file", lambda h: h.replace("kinds:", "data file: LIST\nkinds:"), ["'data file'"]),
    ("missing data file", lambda h: h.replace("kinds:", "data file: nowhere.raw\nkinds:"), ["'data file'", "nowhere.raw"]),
    ("units", lambda h: h.replace("kinds:", 'space units: "mm" "mm" "cm"\nkinds:'), ["'space units'"]),
    ("no type", lambda h: h.replace("type: int16\n", ""), ["'type'", "missing"]),
    ("line", lambda h: h.replace("kinds:", "just words\nkinds:"), ["line"]),
]


@pytest.mark.parametrize("case", NRRD_CASES, ids=[c[0] for c in NRRD_CASES])
def test_malformed_nrrd_headers_name_the_field(tmp_path, case):
    _, edit, words = case
    vol = small_volume(np.int16)
    h = edit(F.nrrd_header(vol, np.eye(4), "gzip"))
    p = tmp_path / "bad.nrrd"
    p.write_bytes(h.encode() + b"\n" + gzip.compress(F.raw_bytes(vol)))
    r = run_cli("info", p, check=False)
    assert r.returncode == 3, r.stdout
    for w in words:
        assert w in r.stderr, (w, r.stderr)


def test_truncated_and_corrupt_nrrd_data(tmp_path):
    vol = small_volume(np.int16)
    h = F.nrrd_header(vol, np.eye(4), "raw").encode() + b"\n"
    (tmp_path / "short.nrrd").write_bytes(h + F.raw_bytes(vol)[:-10])
    r = run_cli("info", tmp_path / "short.nrrd", check=False)
    assert r.returncode == 3 and "too short" in r.stderr
    hz = F.nrrd_header(vol, np.eye(4), "gzip").encode() + b"\n"
    z = gzip.compress(F.raw_bytes(vol))
    (tmp_path / "cut.nrrd").write_bytes(hz + z[: len(z) // 2])
    r = run_cli("info", tmp_path / "cut.nrrd", check=False)
    assert r.returncode == 3 and "gzip" in r.stderr


MHA_CASES = [
    ("ObjectType", lambda h: h.replace("ObjectType = Image", "ObjectType = Tube"), ["'ObjectType'"]),
    ("NDims", lambda h: h.replace("NDims = 3", "NDims = 2"), ["'NDims'"]),
    ("DimSize", lambda h: h.replace("DimSize = 24 20 16", "DimSize = 24 20 x"), ["'DimSize'"]),
    ("ElementType", lambda h: h.replace("ElementType = MET_SHORT", "ElementType = MET_SHORT_ARRAY"),
     ["'ElementType'"]),
    ("ElementSpacing", lambda h: h.replace("ElementSpacing = 1.0", "ElementSpacing = -1.0"), ["'ElementSpacing'"]),
    ("TransformMatrix", lambda h: h.replace("TransformMatrix = ", "TransformMatrix = 1 "), ["'TransformMatrix'"]),
    ("singular", lambda h: re.sub("TransformMatrix = .*", "TransformMatrix = 1 0 0 1 0 0 0 0 1", h),
     ["TransformMatrix", "singular"]),
    ("Offset", lambda h: h.replace("Offset = ", "Offset = nan "), ["'Offset'"]),
    ("alias twice", lambda h: h.replace("Offset = ", "Origin = 0 0 0\nOffset = "), ["twice"]),
    ("BinaryData", lambda h: h.replace("BinaryData = True", "BinaryData = False"), ["'BinaryData'"]),
    ("MSB", lambda h: h.replace("BinaryDataByteOrderMSB = False", "BinaryDataByteOrderMSB = Maybe"),
     ["'BinaryDataByteOrderMSB'"]),
    ("CompressedDataSize", lambda h: h.replace("CompressedDataSize = ", "CompressedDataSize = 9"),
     ["'CompressedDataSize'"]),
    ("channels", lambda h: h.replace("NDims = 3", "NDims = 3\nElementNumberOfChannels = 3"),
     ["'ElementNumberOfChannels'"]),
    ("no ElementDataFile", lambda h: h.replace("ElementDataFile = LOCAL\n", ""), ["'ElementDataFile'"]),
    ("ElementDataFile", lambda h: h.replace("ElementDataFile = LOCAL", "ElementDataFile = LIST"),
     ["'ElementDataFile'"]),
    ("no DimSize", lambda h: h.replace("DimSize = 24 20 16\n", ""), ["'DimSize'", "missing"]),
]


@pytest.mark.parametrize("case", MHA_CASES, ids=[c[0] for c in MHA_CASES])
def test_malformed_metaimage_headers_name_the_field(tmp_path, case):
    import zlib
    _, edit, words = case
    vol = small_volume(np.int16)
    body = zlib.compress(F.raw_bytes(vol))
    h = F.mha_header(vol, np.eye(4), True, size=len(body))
    h2 = edit(h)
    assert h2 != h, "the edit did not apply"
    p = tmp_path / "bad.mha"
    p.write_bytes(h2.encode() + body)
    r = run_cli("info", p, check=False)
    assert r.returncode == 3, r.stdout
    for w in words:
        assert w in r.stderr, (w, r.stderr)


def test_nrrd_spaces_and_spacings(tmp_path):
    vol = small_volume(np.uint8)
    A = np.array([[0.0, -1.2, 0.0, 30.0], [0.9, 0.0, 0.0, -12.5], [0.0, 0.0, 2.0, 7.25], [0, 0, 0, 1]])
    flips = {"right-anterior-superior": [1, 1, 1], "RAS": [1, 1, 1], "left-anterior-superior": [-1, 1, 1],
             "left-posterior-superior": [-1, -1, 1], "LPS": [-1, -1, 1]}

    def info_affine(p):
        r = run_cli("info", p)
        rows = [l for l in r.stdout.splitlines() if l.strip().startswith("[")]
        return np.array([[float(x) for x in l.strip()[1:-1].split()] for l in rows]), r.stdout

    for n, (space, f) in enumerate(flips.items()):
        M, o = np.diag(f) @ A[:3, :3], np.diag(f) @ A[:3, 3]
        h = ("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 24 20 16\nencoding: raw\n"
             f"space: {space}\nspace directions: " +
             " ".join("(%r,%r,%r)" % tuple(M[:, a]) for a in range(3)) + "\nspace origin: (%r,%r,%r)\n\n" % tuple(o))
        p = tmp_path / f"s{n}.nrrd"
        p.write_bytes(h.encode() + F.raw_bytes(vol))
        got, _ = info_affine(p)
        np.testing.assert_allclose(got, A, atol=1e-4, err_msg=space)
    # No space: spacings give a diagonal affine; neither: 1 mm voxels.
    p = tmp_path / "sp.nrrd"
    p.write_bytes(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 24 20 16\nencoding: raw\nspacings: 0.5 2 3\n\n"
                  + F.raw_bytes(vol))
    got, out = info_affine(p)
    np.testing.assert_allclose(got, np.diag([0.5, 2, 3, 1]), atol=1e-9)
    assert "spacings" in out
