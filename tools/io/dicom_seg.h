// ffseg tools: a DICOM Segmentation object (binary) written through DCMTK's
// dcmseg, one segment per object.
//
// Frames are the label map's slices on its own grid (frame rows = j, columns
// = i, one frame per slice that holds the segment, one empty frame for an
// empty segment), each with its ImagePositionPatient and, when the source is a
// DICOM series, a Derivation Image reference to the slice it was drawn on;
// patient, study and frame of reference come from the source series (or a
// generated study, dicom_study.h). Dimensions: the segment number, then the
// slice position.
#ifndef FFSEG_TOOLS_DICOM_SEG_H
#define FFSEG_TOOLS_DICOM_SEG_H

#include <cstdint>
#include <string>
#include <vector>

#include "dicom_series.h"
#include "nifti.h"

namespace ffseg_tools {

struct DicomSegment {
    std::string name;                 // SegmentLabel
    int64_t label = 0;                // its number in the label map (SegmentDescription)
    uint8_t rgb[3] = {255, 0, 0};     // RecommendedDisplayCIELabValue
    const uint8_t* mask = nullptr;    // grid's voxels, i fastest; non-zero = in the segment
};

// grid: the label map's grid (only its geometry is read), the grid of
// `source`'s slices when that is a DICOM series. false with *err on any
// failure.
bool dicom_seg_write(const std::string& path, const NiftiImage& grid, const std::vector<DicomSegment>& segments,
                     const DicomSource& source, std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_DICOM_SEG_H
