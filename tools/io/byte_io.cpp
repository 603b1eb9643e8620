// ffseg tools: the shared byte layer (see byte_io.h).
#include "byte_io.h"

#include <cerrno>
#include <cstdarg>
#include <memory>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace ffseg_tools {
namespace io {

std::string fmt(const char* f, ...) {
    char buf[512];
    va_list ap;
    va_start(ap, f);
    vsnprintf(buf, sizeof buf, f, ap);
    va_end(ap);
    return buf;
}

bool fail(std::string* err, const std::string& msg) {
    if (err) *err = msg;
    return false;
}

void swap_bytes_inplace(uint8_t* p, size_t elem, size_t count) {
    if (elem <= 1) return;
    for (size_t i = 0; i < count; ++i, p += elem) std::reverse(p, p + elem);
}

bool ends_with_ci(const std::string& s, const char* suffix) {
    const size_t n = std::strlen(suffix);
    if (s.size() < n) return false;
    for (size_t i = 0; i < n; ++i) {
        char a = s[s.size() - n + i];
        if (a >= 'A' && a <= 'Z') a = char(a - 'A' + 'a');
        if (a != suffix[i]) return false;
    }
    return true;
}

FILE* open_for_reading(const std::string& path, std::string* err) {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) fail(err, fmt("cannot open '%s': %s", path.c_str(), std::strerror(errno)));
    return f;
}

bool write_file_atomic(const std::string& path, bool gzip,
                       const std::function<bool(Sink&, std::string*)>& body, std::string* err) {
    std::string tmpl = path + ".tmp.XXXXXX";
    std::vector<char> name(tmpl.begin(), tmpl.end());
    name.push_back('\0');
    const int fd = mkstemp(name.data());
    if (fd < 0) return fail(err, fmt("cannot create a temporary file next to '%s': %s", path.c_str(), std::strerror(errno)));
    const std::string tmp(name.data());
    std::string e;
    bool ok;
    {
        FdSink fs(fd);
        if (gzip) {
            GzipSink gz(fs);
            ok = gz.init(&e) && body(gz, &e) && gz.finish(&e);
        } else {
            ok = body(fs, &e) && fs.finish(&e);
        }
    }
    if (ok && ::fchmod(fd, 0644) != 0) {
        ok = false;
        e = fmt("chmod failed: %s", std::strerror(errno));
    }
    if (ok && ::fsync(fd) != 0) {
        ok = false;
        e = fmt("fsync failed: %s", std::strerror(errno));
    }
    if (::close(fd) != 0 && ok) {
        ok = false;
        e = fmt("close failed: %s", std::strerror(errno));
    }
    if (ok && std::rename(tmp.c_str(), path.c_str()) != 0) {
        ok = false;
        e = fmt("rename to final name failed: %s", std::strerror(errno));
    }
    if (!ok) {
        ::unlink(tmp.c_str());
        return fail(err, path + ": " + e);
    }
    return true;
}

}  // namespace io
}  // namespace ffseg_tools
