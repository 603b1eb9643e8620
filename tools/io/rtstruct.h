// ffseg tools: an RT Structure Set written through DCMTK's dcmrt, one ROI
// per object, its contours given (slice_contours.h computes them from the
// meshes) as closed planar polygons in patient coordinates (LPS mm).
//
// With a DICOM source every contour references the image of its slice and
// the structure set references the series (Referenced Frame of Reference ->
// study -> series -> every image); with a generated study (dicom_study.h) it
// references the frame of reference only.
#ifndef FFSEG_TOOLS_RTSTRUCT_H
#define FFSEG_TOOLS_RTSTRUCT_H

#include <cstdint>
#include <string>
#include <vector>

#include "dicom_series.h"
#include "nifti.h"

namespace ffseg_tools {

struct RtContour {
    int slice = 0;            // k of the grid: the image it lies on
    std::vector<double> lps;  // x, y, z per point, LPS mm; closed (the last point joins the first)
};

struct RtRoi {
    std::string name;         // ROIName
    int64_t number = 0;       // ROINumber: the object's label
    uint8_t rgb[3] = {255, 0, 0};
    std::vector<RtContour> contours;
};

bool rtstruct_write(const std::string& path, const NiftiImage& grid, const std::vector<RtRoi>& rois,
                    const DicomSource& source, std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_RTSTRUCT_H
