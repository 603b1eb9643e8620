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
#ifndef FFSEG_TOOLS_DICOM_SERIES_H
#define FFSEG_TOOLS_DICOM_SERIES_H

#include <string>
#include <vector>

#include "nifti.h"

namespace ffseg_tools {

// What the DICOM objects ffseg writes (dicom_seg.h, rtstruct.h) refer to: the
// series the image was read from, or, for any other input, a study generated
// for them (no source image to reference).
struct DicomSource {
    std::vector<std::string> files;              // slice k's file (empty: generated)
    std::vector<std::string> sop_instance_uids;  // slice k's SOPInstanceUID
    std::string sop_class_uid, study_uid, series_uid, frame_of_reference_uid;
    std::string note;  // what the objects cannot reference (no source image, no frame of reference)
    bool generated() const { return files.empty(); }
};

// *source (may be null) gets the series' identifiers, slices in the image's
// k order; a slice without SOPInstanceUID or StudyInstanceUID is then an
// error (a series without FrameOfReferenceUID leaves it empty).
bool dicom_read_series(const std::string& directory, NiftiImage* out, std::string* err,
                       const NiftiLimits& lim = {}, DicomSource* source = nullptr);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_DICOM_SERIES_H
