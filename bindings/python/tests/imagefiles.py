"""Test-side writers of NRRD, MetaImage and DICOM files, written from the
format descriptions (not with ffseg's writers), so that the readers are
checked against an independent encoder. Volumes are array[i, j, k] with a
RAS index-to-world affine; NRRD space LPS, MetaImage and DICOM are LPS."""
import gzip
import os
import zlib

import numpy as np

LPS = np.diag([-1.0, -1.0, 1.0])
NRRD_TYPES = {"uint8": "uint8", "int16": "int16", "uint16": "uint16", "int32": "int32",
              "float32": "float", "float64": "double"}
MET_TYPES = {"uint8": "MET_UCHAR", "int16": "MET_SHORT", "uint16": "MET_USHORT",
             "int32": "MET_INT", "float32": "MET_FLOAT", "float64": "MET_DOUBLE"}


def g(x):
    return repr(float(x))


def ds(x):
    """A DICOM decimal string (at most 16 characters)."""
    return "%.10g" % float(x)


def raw_bytes(vol, big_endian=False):
    a = np.asarray(vol)
    dt = a.dtype.newbyteorder(">" if big_endian else "<")
    return a.astype(dt).tobytes(order="F")  # i fastest


def lps(affine):
    A = np.asarray(affine, float)
    return LPS @ A[:3, :3], LPS @ A[:3, 3]


def nrrd_header(vol, affine, encoding="gzip", data_file=None, big_endian=False, extra=()):
    M, o = lps(affine)
    lines = ["NRRD0004", "# test file", f"type: {NRRD_TYPES[vol.dtype.name]}", "dimension: 3",
             "space: left-posterior-superior", "sizes: %d %d %d" % vol.shape,
             "space directions: " + " ".join("(%s,%s,%s)" % tuple(g(v) for v in M[:, a]) for a in range(3)),
             "kinds: domain domain domain", f"endian: {'big' if big_endian else 'little'}",
             f"encoding: {encoding}", "space origin: (%s,%s,%s)" % tuple(g(v) for v in o)]
    lines += list(extra)
    if data_file:
        lines.append(f"data file: {data_file}")
    return "\n".join(lines) + "\n"


def write_nrrd(path, vol, affine, encoding="gzip", big_endian=False):
    data = raw_bytes(vol, big_endian)
    with open(path, "wb") as f:
        f.write(nrrd_header(vol, affine, encoding, big_endian=big_endian).encode() + b"\n")
        f.write(gzip.compress(data) if encoding == "gzip" else data)


def write_nhdr(path, vol, affine, encoding="raw"):
    base = os.path.splitext(os.path.basename(path))[0] + (".raw" if encoding == "raw" else ".raw.gz")
    with open(os.path.join(os.path.dirname(path), base), "wb") as f:
        f.write(raw_bytes(vol) if encoding == "raw" else gzip.compress(raw_bytes(vol)))
    with open(path, "w") as f:
        f.write(nrrd_header(vol, affine, encoding, data_file=base))


def mha_header(vol, affine, compressed, data_file="LOCAL", size=None, msb=False):
    M, o = lps(affine)
    sp = np.linalg.norm(M, axis=0)
    dirs = (M / sp).T.reshape(9)  # the i axis' direction first
    h = ["ObjectType = Image", "NDims = 3", "BinaryData = True",
         f"BinaryDataByteOrderMSB = {msb}", f"CompressedData = {compressed}"]
    if size is not None:
        h.append(f"CompressedDataSize = {size}")
    h += ["TransformMatrix = " + " ".join(g(v) for v in dirs), "Offset = " + " ".join(g(v) for v in o),
          "CenterOfRotation = 0 0 0", "AnatomicalOrientation = RAI",
          "ElementSpacing = " + " ".join(g(v) for v in sp), "DimSize = %d %d %d" % vol.shape,
          f"ElementType = {MET_TYPES[vol.dtype.name]}", f"ElementDataFile = {data_file}"]
    return "\n".join(h) + "\n"


def write_mha(path, vol, affine, compressed=True):
    data = raw_bytes(vol)
    if compressed:
        data = zlib.compress(data)
    with open(path, "wb") as f:
        f.write(mha_header(vol, affine, compressed, size=len(data) if compressed else None).encode())
        f.write(data)


def write_mhd(path, vol, affine):
    base = os.path.splitext(os.path.basename(path))[0] + ".raw"
    with open(os.path.join(os.path.dirname(path), base), "wb") as f:
        f.write(raw_bytes(vol))
    with open(path, "w") as f:
        f.write(mha_header(vol, affine, False, data_file=base))


def write_dicom_series(directory, vol, affine, slope=1.0, intercept=0.0, stored=None, order=None,
                       slice_thickness=7.5, series_uid=None, with_frame_of_reference=True):
    """One single-frame MR slice per k, in LPS; file names in `order` (a
    permutation of the slices) so that name order is not position order."""
    import pydicom
    from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid
    os.makedirs(directory, exist_ok=True)
    M, o = lps(affine)
    sp = np.linalg.norm(M, axis=0)
    row_dir, col_dir = M[:, 0] / sp[0], M[:, 1] / sp[1]
    stored = vol if stored is None else stored
    series_uid = series_uid or generate_uid()
    study, frame_of_reference = generate_uid(), generate_uid()
    nk = vol.shape[2]
    order = list(range(nk)) if order is None else order
    for n, k in enumerate(order):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.4"
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        d = FileDataset(None, Dataset(), file_meta=meta, preamble=b"\0" * 128)
        d.is_little_endian, d.is_implicit_VR = True, False
        d.SOPClassUID = meta.MediaStorageSOPClassUID
        d.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        d.StudyInstanceUID, d.SeriesInstanceUID = study, series_uid
        if with_frame_of_reference:
            d.FrameOfReferenceUID = frame_of_reference
        d.Modality, d.PatientName, d.PatientID = "MR", "Test^Phantom", "ffseg-test"
        d.InstanceNumber = n + 1
        d.ImagePositionPatient = [ds(v) for v in o + M[:, 2] * k]
        d.ImageOrientationPatient = [ds(v) for v in np.concatenate([row_dir, col_dir])]
        d.PixelSpacing = [ds(sp[1]), ds(sp[0])]  # row spacing (along j), column spacing (along i)
        d.SliceThickness = ds(slice_thickness)  # deliberately not the spacing
        d.RescaleSlope, d.RescaleIntercept = ds(slope), ds(intercept)
        plane = np.ascontiguousarray(stored[:, :, k].T)  # rows = j, columns = i
        d.Rows, d.Columns = plane.shape
        d.SamplesPerPixel, d.PhotometricInterpretation = 1, "MONOCHROME2"
        bits = plane.dtype.itemsize * 8
        d.BitsAllocated, d.BitsStored, d.HighBit = bits, bits, bits - 1
        d.PixelRepresentation = 1 if plane.dtype.kind == "i" else 0
        d.PixelData = plane.astype(plane.dtype.newbyteorder("<")).tobytes()
        d.save_as(os.path.join(directory, f"IM{n:04d}.dcm"), write_like_original=False)


def read_nrrd(path):
    """The test's own reader of what ffseg writes (attached gzip, LPS)."""
    data = open(path, "rb").read()
    end = data.index(b"\n\n")
    fields = dict(l.split(": ", 1) for l in data[:end].decode().splitlines()[1:] if not l.startswith("#"))
    assert fields["space"] == "left-posterior-superior" and fields["encoding"] == "gzip"
    sizes = tuple(int(x) for x in fields["sizes"].split())
    dt = {v: k for k, v in NRRD_TYPES.items()}[fields["type"]]
    vol = np.frombuffer(gzip.decompress(data[end + 2:]), np.dtype(dt).newbyteorder("<")).reshape(sizes, order="F")
    dirs = [np.array([float(x) for x in v.strip("()").split(",")]) for v in fields["space directions"].split()]
    A = np.eye(4)
    A[:3, :3] = LPS @ np.stack(dirs, axis=1)
    A[:3, 3] = LPS @ np.array([float(x) for x in fields["space origin"].strip("()").split(",")])
    return vol, A


def read_mha(path):
    data = open(path, "rb").read()
    end = data.index(b"ElementDataFile = LOCAL\n") + len(b"ElementDataFile = LOCAL\n")
    f = dict(l.split(" = ", 1) for l in data[:end].decode().splitlines())
    sizes = tuple(int(x) for x in f["DimSize"].split())
    dt = {v: k for k, v in MET_TYPES.items()}[f["ElementType"]]
    body = data[end:]
    assert f["CompressedData"] == "True" and int(f["CompressedDataSize"]) == len(body)
    vol = np.frombuffer(zlib.decompress(body), np.dtype(dt).newbyteorder("<")).reshape(sizes, order="F")
    dirs = np.array([float(x) for x in f["TransformMatrix"].split()]).reshape(3, 3).T
    sp = np.array([float(x) for x in f["ElementSpacing"].split()])
    A = np.eye(4)
    A[:3, :3] = LPS @ (dirs * sp)
    A[:3, 3] = LPS @ np.array([float(x) for x in f["Offset"].split()])
    return vol, A
