// ffseg tools: a DICOM series (one directory of single-frame slices) read
// through GDCM; no DICOM parsing of our own.
//
// Policy:
//  * Every regular file of the directory is a slice of one series (hidden
//    files and DICOMDIR are skipped; any other file GDCM cannot read as an
//    image is an error naming it; two SeriesInstanceUIDs are an error).
//  * One sample per pixel, one frame per file, the same Rows, Columns, pixel
//    type, ImageOrientationPatient and PixelSpacing in every slice.
//  * Slices are sorted by ImagePositionPatient along the normal (row x column
//    direction); the slice step is taken from the positions (their mean step;
//    every position must lie on it within 0.01 mm: a missing or duplicate
//    slice is an error), never from SliceThickness.
//  * RescaleSlope / RescaleIntercept: when every slice has the same pair it
//    becomes the image's slope and intercept (stored values kept); otherwise
//    each slice is rescaled into float64.
//  * World frame: DICOM's LPS, converted to the tools' RAS (image_common.h).
//    Voxel (i, j, k) = column i, row j, slice k.
#ifndef FFSEG_TOOLS_DICOM_H
#define FFSEG_TOOLS_DICOM_H

#include <string>

#include "nifti.h"

namespace ffseg_tools {

bool dicom_read_series(const std::string& directory, NiftiImage* out, std::string* err,
                       const NiftiLimits& lim = {});

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_DICOM_H
