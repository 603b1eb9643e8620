// `ffseg segment`'s DICOM objects (dicom_outputs.h).
#include "dicom_outputs.h"

#include "cli.h"
#include "dicom_seg.h"
#include "overlay.h"
#include "rtstruct.h"
#include "slice_contours.h"

namespace ffseg_cli {

void write_dicom_seg(const std::string& path, const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res,
                     const std::vector<std::string>& names, const std::vector<int64_t>& labels,
                     const ffseg_tools::DicomSource& source) {
  std::vector<ffseg_tools::DicomSegment> segs(res.size());
  for (size_t k = 0; k < res.size(); ++k) {
    segs[k].name = names[k];
    segs[k].label = labels[k];
    ffseg_tools::overlay_palette(k, segs[k].rgb);
    segs[k].mask = res[k].mask.data();
  }
  std::string err;
  if (!ffseg_tools::dicom_seg_write(path, img, segs, source, &err)) fail(kExitFailure, err);
}

void write_rtstruct(const std::string& path, const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res,
                    const std::vector<std::string>& names, const std::vector<int64_t>& labels,
                    const ffseg_tools::DicomSource& source, size_t* contours) {
  std::vector<ffseg_tools::RtRoi> rois(res.size());
  std::string err;
  *contours = 0;
  for (size_t k = 0; k < res.size(); ++k) {
    ffseg_tools::RtRoi& roi = rois[k];
    roi.name = names[k];
    roi.number = labels[k];
    ffseg_tools::overlay_palette(k, roi.rgb);
    std::vector<ffseg_tools::SliceContour> cut;
    if (!ffseg_tools::grid_slice_contours(res[k].xyz.data(), res[k].xyz.size() / 3, res[k].tris.data(),
                                          res[k].tris.size() / 3, img, &cut, &err))
      fail(kExitFailure, "--rtstruct: " + names[k] + ": " + err);
    for (const ffseg_tools::SliceContour& c : cut) {
      ffseg_tools::RtContour rc;
      rc.slice = c.slice;
      // RAS -> DICOM's LPS.
      for (const auto& p : c.points) rc.lps.insert(rc.lps.end(), {-p[0], -p[1], p[2]});
      roi.contours.push_back(std::move(rc));
    }
    *contours += roi.contours.size();
  }
  if (!ffseg_tools::rtstruct_write(path, img, rois, source, &err)) fail(kExitFailure, err);
}

}  // namespace ffseg_cli
