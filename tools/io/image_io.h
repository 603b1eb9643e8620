// ffseg tools: one entry point for every image format the tools read, and
// the label-map writer in the input's format family.
//
//   format      read from                               labels written as
//   nifti       .nii, .nii.gz (and any other name)      labels.nii.gz
//   nrrd        .nrrd, .nhdr (+ data file)              labels.nrrd
//   metaimage   .mha, .mhd (+ data file)                labels.mha
//   dicom       a directory holding one series (GDCM)   labels.nii.gz (no label family)
//
// Every reader returns the image in the tools' RAS world frame (see
// image_common.h), so coordinates mean the same point whatever the format.
#ifndef FFSEG_TOOLS_IMAGE_IO_H
#define FFSEG_TOOLS_IMAGE_IO_H

#include <string>

#include "dicom_series.h"
#include "nifti.h"

namespace ffseg_tools {

enum class ImageFormat { Nifti, Nrrd, MetaImage, Dicom };

const char* image_format_name(ImageFormat f);  // "nifti", "nrrd", "metaimage", "dicom"
// "nifti", "nrrd", "metaimage" (or "mha"), "dicom"; false for anything else.
bool image_format_from_name(const std::string& name, ImageFormat* f);
// By the path: a directory is DICOM, then by extension; other names are
// sniffed ("NRRD000" -> nrrd, "ObjectType"/"NDims" -> metaimage, else nifti).
ImageFormat image_format_of_path(const std::string& path);

// Reads any supported image; *format (may be null) gets its format and
// *dicom (may be null) a DICOM series' identifiers (dicom_series.h; left
// empty for the other formats).
bool image_read_file(const std::string& path, NiftiImage* out, ImageFormat* format, std::string* err,
                     const NiftiLimits& lim = {}, DicomSource* dicom = nullptr);

// The label map's file name for a format family, and the writer by format
// (nifti: gzip .nii.gz, nrrd: gzip .nrrd, metaimage: zlib .mha). DICOM has
// no label family: the NIfTI writer is used.
const char* label_file_name(ImageFormat f);
bool image_write_file(const std::string& path, ImageFormat f, const NiftiImage& img, std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_IMAGE_IO_H
