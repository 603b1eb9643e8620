// ffseg tools: a generated study for non-DICOM input (dicom_study.h).
#include "dicom_study.h"

#include <ctime>

#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcuid.h>

namespace ffseg_tools {

std::string dicom_new_uid() {
    char b[100];
    dcmGenerateUniqueIdentifier(b, SITE_INSTANCE_UID_ROOT);
    return b;
}

std::string dicom_now(const char* format) {
    char b[32];
    const std::time_t t = std::time(nullptr);
    std::tm tm;
    gmtime_r(&t, &tm);
    std::strftime(b, sizeof b, format, &tm);
    return b;
}

DicomSource dicom_generated_source(const std::string& input_path) {
    DicomSource s;
    s.study_uid = dicom_new_uid();
    s.frame_of_reference_uid = dicom_new_uid();
    s.note = "made from " + input_path + ", which is not a DICOM series: a generated study, no source image referenced";
    return s;
}

}  // namespace ffseg_tools
