// ffseg tools: the DICOM writers' shared DCMTK handling (dicom_write.h).
#include "dicom_write.h"

#include <exception>

#include <dcmtk/oflog/oflog.h>

namespace ffseg_tools {

bool DcmtkCheck::operator()(const OFCondition& c, const std::string& what) {
    if (ok && c.bad()) {
        *err = what + ": " + c.text();
        ok = false;
    }
    return ok;
}

bool dicom_write_guarded(const char* object, const std::string& path, const std::function<bool(std::string*)>& write,
                         std::string* err) {
    static const bool quiet = [] {
        OFLog::configure(OFLogger::ERROR_LOG_LEVEL);
        return true;
    }();
    (void)quiet;
    std::string e;
    bool ok = false;
    try {
        ok = write(&e);
    } catch (const std::exception& ex) {
        e = ex.what();
    }
    if (!ok) *err = std::string("cannot write the ") + object + " " + path + ": " + e;
    return ok;
}

}  // namespace ffseg_tools
