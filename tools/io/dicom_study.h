// ffseg tools: the study a DICOM object ffseg writes belongs to when the
// input was not a DICOM series (NIfTI, NRRD, MetaImage): new Study and
// Frame of Reference UIDs shared by every object of the run, and a note that
// no source image is referenced; and the UIDs the writers need (DCMTK's
// generator, its root).
#ifndef FFSEG_TOOLS_DICOM_STUDY_H
#define FFSEG_TOOLS_DICOM_STUDY_H

#include <string>

#include "dicom_series.h"

namespace ffseg_tools {

std::string dicom_new_uid();
// The current UTC date or time by strftime format ("%Y%m%d", "%H%M%S").
std::string dicom_now(const char* format);

// A DicomSource with no files: generated study and frame of reference UIDs,
// the note naming input_path.
DicomSource dicom_generated_source(const std::string& input_path);

// The patient of a generated study (no patient data is known).
constexpr const char* kGeneratedPatientName = "ffseg^generated";
constexpr const char* kGeneratedPatientId = "FFSEG-GENERATED";

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_DICOM_STUDY_H
