// `ffseg segment`'s DICOM objects: the DICOM Segmentation from the objects'
// voxels and the RT Structure Set from their meshes cut by the slice planes,
// both referencing the input series (or a generated study for other input).
#ifndef FFSEG_CLI_DICOM_OUTPUTS_H
#define FFSEG_CLI_DICOM_OUTPUTS_H

#include <cstdint>
#include <string>
#include <vector>

#include "dicom_series.h"
#include "nifti.h"
#include "segment_outputs.h"

namespace ffseg_cli {

// DIR's DICOM Segmentation when the input is a DICOM series and no
// --dicom-seg is given.
constexpr const char* kAutoSegFile = "segmentation.dcm";

// Object k: res[k].mask (the label map's voxels), names[k], labels[k], the
// overlay's colour k. fail(kExitFailure) when it cannot be written.
void write_dicom_seg(const std::string& path, const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res,
                     const std::vector<std::string>& names, const std::vector<int64_t>& labels,
                     const ffseg_tools::DicomSource& source);
// Object k's contours: res[k]'s mesh cut by every slice plane of img.
// *contours gets the number of contours written.
void write_rtstruct(const std::string& path, const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res,
                    const std::vector<std::string>& names, const std::vector<int64_t>& labels,
                    const ffseg_tools::DicomSource& source, size_t* contours);

}  // namespace ffseg_cli

#endif  // FFSEG_CLI_DICOM_OUTPUTS_H
