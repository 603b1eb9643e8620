// ffseg tools: a grid's slices as DICOM describes them (LPS mm): the row and
// column directions (ImageOrientationPatient), PixelSpacing, and each slice's
// ImagePositionPatient. Shared by the DICOM SEG and RT Structure Set writers.
#ifndef FFSEG_TOOLS_DICOM_PLANES_H
#define FFSEG_TOOLS_DICOM_PLANES_H

#include <array>
#include <string>
#include <vector>

#include "nifti.h"

namespace ffseg_tools {

struct DicomPlanes {
    double row_dir[3], col_dir[3];  // unit: along i (a row) and along j (a column)
    double row_spacing, col_spacing;  // mm between rows (j step) and columns (i step)
    double slice_thickness;           // the k step's length along the normal
    std::vector<std::array<double, 3>> positions;  // slice k's voxel (0, 0, k)
};

// false with *err when DICOM cannot describe the grid's slices: i and j not
// orthogonal (within 1e-4), or more than 65535 rows or columns.
bool dicom_planes(const NiftiImage& grid, DicomPlanes* out, std::string* err);

// A Decimal String value (at most 16 characters) as close to v as it holds.
std::string dicom_ds(double v);
// Several, separated by '\'.
std::string dicom_ds_list(const double* v, size_t n);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_DICOM_PLANES_H
