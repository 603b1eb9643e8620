// ffseg tools: what the DICOM writers (dicom_seg, rtstruct) share around
// DCMTK: its conditions checked and named, its console warnings off, its
// exceptions caught, one message naming the file.
#ifndef FFSEG_TOOLS_DICOM_WRITE_H
#define FFSEG_TOOLS_DICOM_WRITE_H

#include <functional>
#include <string>

#include <dcmtk/config/osconfig.h>
#include <dcmtk/ofstd/ofcond.h>

namespace ffseg_tools {

// Keeps the first failed DCMTK call: *err = "<what>: <DCMTK's text>".
struct DcmtkCheck {
    std::string* err;
    bool ok = true;
    bool operator()(const OFCondition& c, const std::string& what);
};

// Runs write(&e) with DCMTK's warnings off (the writers report failures
// themselves) and exceptions caught; on failure *err = "cannot write the
// <object> <path>: <e>".
bool dicom_write_guarded(const char* object, const std::string& path, const std::function<bool(std::string*)>& write,
                         std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_DICOM_WRITE_H
