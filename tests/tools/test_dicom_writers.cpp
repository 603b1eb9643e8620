// Tests for tools/io/dicom_seg and tools/io/rtstruct, read back with DCMTK
// (the Python tests read them with pydicom and check them with dciodvfy): the
// SEG's bits are each frame's voxels with no padding between frames, on a grid
// whose frames are not a whole number of bytes (the packing DCMTK 3.6.7 gets
// wrong); the RT Structure Set's contours are the points given, in order.
#include <doctest/doctest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcitem.h>

#include "dicom_seg.h"
#include "dicom_study.h"
#include "nifti.h"
#include "rtstruct.h"

using namespace ffseg_tools;

namespace {

struct TmpFile {
  std::string path;
  explicit TmpFile(const char* name) {
    char t[] = "/tmp/ffseg_dicom_XXXXXX";
    REQUIRE(mkdtemp(t) != nullptr);
    dir = t;
    path = dir + "/" + name;
  }
  ~TmpFile() {
    std::remove(path.c_str());
    rmdir(dir.c_str());
  }
  std::string dir;
};

// 5 x 3 x 4 voxels (15 bits a frame), 1 x 1.5 x 2 mm.
NiftiImage grid() {
  NiftiImage g;
  g.dims[0] = 5, g.dims[1] = 3, g.dims[2] = 4;
  const double m[16] = {1, 0, 0, -2, 0, 1.5, 0, 3, 0, 0, 2, 10, 0, 0, 0, 1};
  for (int q = 0; q < 16; ++q) g.index_to_world[q] = m[q];
  return g;
}

std::string text(DcmItem* item, const DcmTagKey& tag) {
  OFString v;
  if (item->findAndGetOFStringArray(tag, v, OFTrue).bad()) return "";
  return v.c_str();
}

}  // namespace

TEST_CASE("dicom seg: frames hold each segment's voxels bit for bit, frames not a whole number of bytes") {
  const NiftiImage g = grid();
  const size_t n = 5 * 3 * 4, per = 15;
  std::vector<uint8_t> a(n, 0), b(n, 0);
  // a: a diagonal in slices 1 and 2; b: every voxel of slice 3 but one.
  for (int k = 1; k <= 2; ++k)
    for (int i = 0; i < 3; ++i) a[size_t(k) * per + size_t(i) * 6] = 1;
  for (size_t q = 0; q < per - 1; ++q) b[3 * per + q] = 1;
  std::vector<DicomSegment> segs(2);
  segs[0].name = "first", segs[0].label = 4, segs[0].mask = a.data();
  segs[1].name = "second", segs[1].label = 9, segs[1].mask = b.data();
  TmpFile f("seg.dcm");
  std::string err;
  REQUIRE_MESSAGE(dicom_seg_write(f.path, g, segs, dicom_generated_source("test.nii.gz"), &err), err);

  DcmFileFormat file;
  REQUIRE(file.loadFile(f.path.c_str()).good());
  DcmDataset* ds = file.getDataset();
  CHECK(text(ds, DCM_Modality) == "SEG");
  CHECK(text(ds, DCM_Rows) == "3");
  CHECK(text(ds, DCM_Columns) == "5");
  // Frames: a in slices 1, 2; b in slice 3.
  CHECK(text(ds, DCM_NumberOfFrames) == "3");
  const Uint8* pix = nullptr;
  unsigned long len = 0;
  REQUIRE(ds->findAndGetUint8Array(DCM_PixelData, pix, &len).good());
  CHECK(len == (3 * per + 7) / 8 + ((3 * per + 7) / 8) % 2);  // even length
  const int want_slice[3] = {1, 2, 3};
  const uint8_t* want_mask[3] = {a.data(), a.data(), b.data()};
  for (int f_no = 0; f_no < 3; ++f_no)
    for (size_t q = 0; q < per; ++q) {
      const size_t bit = size_t(f_no) * per + q;
      const bool set = (pix[bit >> 3] >> (bit & 7)) & 1;
      CHECK(set == bool(want_mask[f_no][size_t(want_slice[f_no]) * per + q]));
    }
  DcmItem* frame2 = nullptr;
  REQUIRE(ds->findAndGetSequenceItem(DCM_PerFrameFunctionalGroupsSequence, frame2, 2).good());
  DcmItem* pos = nullptr;
  REQUIRE(frame2->findAndGetSequenceItem(DCM_PlanePositionSequence, pos, 0).good());
  CHECK(text(pos, DCM_ImagePositionPatient) == "2\\-3\\16");  // LPS of voxel (0, 0, 3)
  DcmItem* seg1 = nullptr;
  REQUIRE(ds->findAndGetSequenceItem(DCM_SegmentSequence, seg1, 1).good());
  CHECK(text(seg1, DCM_SegmentLabel) == "second");
  CHECK(text(seg1, DCM_SegmentDescription) == "label 9");
}

TEST_CASE("rtstruct: ROIs, contours and their points as given; a contour off the grid refused") {
  const NiftiImage g = grid();
  RtRoi roi;
  roi.name = "square";
  roi.number = 7;
  RtContour c;
  c.slice = 2;
  c.lps = {0, 0, 14, 1.5, 0, 14, 1.5, -2.25, 14, 0, -2.25, 14};
  roi.contours = {c, c};
  roi.contours[1].slice = 3;
  for (size_t q = 2; q < 12; q += 3) roi.contours[1].lps[q] = 16;
  TmpFile f("rt.dcm");
  std::string err;
  REQUIRE_MESSAGE(rtstruct_write(f.path, g, {roi}, dicom_generated_source("test.nii.gz"), &err), err);
  DcmFileFormat file;
  REQUIRE(file.loadFile(f.path.c_str()).good());
  DcmDataset* ds = file.getDataset();
  CHECK(text(ds, DCM_Modality) == "RTSTRUCT");
  DcmItem* ssroi = nullptr;
  REQUIRE(ds->findAndGetSequenceItem(DCM_StructureSetROISequence, ssroi, 0).good());
  CHECK(text(ssroi, DCM_ROINumber) == "7");
  CHECK(text(ssroi, DCM_ROIName) == "square");
  DcmItem* rc = nullptr;
  REQUIRE(ds->findAndGetSequenceItem(DCM_ROIContourSequence, rc, 0).good());
  DcmItem* c1 = nullptr;
  REQUIRE(rc->findAndGetSequenceItem(DCM_ContourSequence, c1, 1).good());
  CHECK(text(c1, DCM_ContourGeometricType) == "CLOSED_PLANAR");
  CHECK(text(c1, DCM_NumberOfContourPoints) == "4");
  CHECK(text(c1, DCM_ContourData) == "0\\0\\16\\1.5\\0\\16\\1.5\\-2.25\\16\\0\\-2.25\\16");

  roi.contours[0].slice = 4;  // the grid has slices 0..3
  CHECK_FALSE(rtstruct_write(f.path, g, {roi}, dicom_generated_source("test.nii.gz"), &err));
  CHECK(err.find("not a polygon on a slice of the grid") != std::string::npos);
}
