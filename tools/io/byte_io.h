// ffseg tools: the byte layer every image reader and writer shares: sources
// (memory, a file, a bounded streaming gzip decoder on top of either), sinks
// (memory, a file descriptor, gzip), and a file write that never leaves a
// partial file behind. Tool-side only; the core never links it.
#ifndef FFSEG_TOOLS_BYTE_IO_H
#define FFSEG_TOOLS_BYTE_IO_H

#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace ffseg_tools {
namespace io {

std::string fmt(const char* f, ...) __attribute__((format(printf, 1, 2)));
// Sets *err (if non-null) and returns false.
bool fail(std::string* err, const std::string& msg);
void swap_bytes_inplace(uint8_t* p, size_t elem, size_t count);
bool ends_with_ci(const std::string& s, const char* suffix);

template <class T>
T load(const uint8_t* p) {
    T v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
template <class T>
void store(uint8_t* p, T v) {
    std::memcpy(p, &v, sizeof v);
}

// ------------------------------------------------------------ byte sources
class Source {
public:
    virtual ~Source() = default;
    // Reads up to n bytes.  Returns false on error.  *got < n means the end
    // of the stream was reached (and, for gzip, the stream was verified).
    virtual bool read(uint8_t* dst, size_t n, size_t* got, std::string* err) = 0;
    // Bytes left to read, if known without reading (uncompressed memory or a
    // regular file); lets the reader refuse a truncated file before it
    // allocates the voxel buffer.
    virtual bool remaining(uint64_t*) const { return false; }
    // Compressed bytes left, if known (a gzip stream over a regular file or
    // memory): what the reader may size a first buffer by.
    virtual bool compressed_remaining(uint64_t*) const { return false; }
};

class MemSource final : public Source {
public:
    MemSource(const uint8_t* p, size_t n) : p_(p), n_(n) {}
    bool read(uint8_t* dst, size_t n, size_t* got, std::string*) override {
        const size_t k = std::min(n, n_ - pos_);
        if (k) std::memcpy(dst, p_ + pos_, k);
        pos_ += k;
        *got = k;
        return true;
    }
    bool remaining(uint64_t* r) const override {
        *r = n_ - pos_;
        return true;
    }

private:
    const uint8_t* p_;
    size_t n_;
    size_t pos_ = 0;
};

// A FILE* with a small push-back prefix (used to sniff the gzip magic).
class FileSource final : public Source {
public:
    // Reads on from f's current position (consumed_ starts there, so
    // remaining() is right after a header read with stdio).
    explicit FileSource(FILE* f) : f_(f) {
        const long at = std::ftell(f);
        consumed_ = at > 0 ? uint64_t(at) : 0;
        struct stat st;
        if (::fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode) && st.st_size >= 0) {
            size_known_ = true;
            size_ = uint64_t(st.st_size);
        }
    }
    // Un-read the n bytes just read (at most a few).
    void push_prefix(const uint8_t* p, size_t n) {
        prefix_.assign(p, p + n);
        ppos_ = 0;
        consumed_ -= n;
    }
    bool read(uint8_t* dst, size_t n, size_t* got, std::string* err) override {
        size_t done = 0;
        if (ppos_ < prefix_.size()) {
            const size_t k = std::min(n, prefix_.size() - ppos_);
            std::memcpy(dst, prefix_.data() + ppos_, k);
            ppos_ += k;
            done = k;
        }
        while (done < n) {
            const size_t k = std::fread(dst + done, 1, n - done, f_);
            done += k;
            if (k == 0) {
                if (std::ferror(f_)) return fail(err, fmt("read error: %s", std::strerror(errno)));
                break;
            }
        }
        *got = done;
        consumed_ += done;
        return true;
    }
    bool remaining(uint64_t* r) const override {
        if (!size_known_) return false;
        *r = size_ > consumed_ ? size_ - consumed_ : 0;
        return true;
    }

private:
    FILE* f_;
    bool size_known_ = false;
    uint64_t size_ = 0;
    uint64_t consumed_ = 0;
    std::vector<uint8_t> prefix_;
    size_t ppos_ = 0;
};

// Streaming gzip decoder on top of another source.  Accepts concatenated
// gzip members (as written by pigz / bgzip) and trailing zero padding;
// anything else after a member is decoded as a member and so fails.
class GzipSource final : public Source {
public:
    explicit GzipSource(Source& in) : in_(in), inbuf_(size_t(1) << 16) { std::memset(&zs_, 0, sizeof zs_); }
    ~GzipSource() override {
        if (inited_) inflateEnd(&zs_);
    }
    bool init(std::string* err) {
        if (inflateInit2(&zs_, 15 + 32) != Z_OK) return fail(err, "gzip: inflateInit2 failed");
        inited_ = true;
        return true;
    }
    void set_limit(uint64_t limit) { limit_ = limit; }
    bool compressed_remaining(uint64_t* r) const override {
        if (!in_.remaining(r)) return false;
        *r += zs_.avail_in;
        return true;
    }
    uint64_t produced() const { return produced_; }

    bool read(uint8_t* dst, size_t n, size_t* got, std::string* err) override {
        *got = 0;
        while (*got < n && !finished_) {
            if (zs_.avail_in == 0 && !in_eof_ && !refill(err)) return false;
            const size_t want = std::min<size_t>(n - *got, size_t(1) << 30);
            zs_.next_out = dst + *got;
            zs_.avail_out = uInt(want);
            const int r = inflate(&zs_, Z_NO_FLUSH);
            const size_t made = want - zs_.avail_out;
            *got += made;
            produced_ += made;
            if (produced_ > limit_)
                return fail(err, fmt("gzip stream exceeds the decompression bound of %llu bytes "
                                     "(possible decompression bomb)",
                                     (unsigned long long)limit_));
            if (r == Z_STREAM_END) {
                if (!next_member(err)) return false;
                continue;
            }
            if (r == Z_OK) continue;
            if (r == Z_BUF_ERROR) {
                if (zs_.avail_in == 0 && in_eof_)
                    return fail(err, fmt("gzip stream truncated (after %llu decompressed bytes)",
                                         (unsigned long long)produced_));
                continue;
            }
            if (r == Z_MEM_ERROR) return fail(err, "gzip: out of memory in inflate");
            return fail(err, fmt("gzip data corrupt (%s)", zs_.msg ? zs_.msg : "inflate error"));
        }
        return true;
    }

private:
    bool refill(std::string* err) {
        size_t got = 0;
        if (!in_.read(inbuf_.data(), inbuf_.size(), &got, err)) return false;
        if (got < inbuf_.size()) in_eof_ = true;
        zs_.next_in = inbuf_.data();
        zs_.avail_in = uInt(got);
        return true;
    }
    // Called after Z_STREAM_END: decide between "done", "zero padding" and
    // "another member".
    bool next_member(std::string* err) {
        for (;;) {
            if (zs_.avail_in == 0) {
                if (in_eof_) {
                    finished_ = true;
                    return true;
                }
                if (!refill(err)) return false;
                continue;
            }
            if (zs_.next_in[0] == 0) {
                // Zero padding: every remaining byte must be zero.
                zero_pad_ = true;
                for (uInt i = 0; i < zs_.avail_in; ++i)
                    if (zs_.next_in[i] != 0) return fail(err, "gzip: garbage after the compressed stream");
                zs_.avail_in = 0;
                continue;
            }
            if (zero_pad_) return fail(err, "gzip: garbage after the compressed stream");
            if (inflateReset(&zs_) != Z_OK) return fail(err, "gzip: inflateReset failed");
            return true;
        }
    }

    Source& in_;
    std::vector<uint8_t> inbuf_;
    z_stream zs_;
    bool inited_ = false;
    bool in_eof_ = false;
    bool finished_ = false;
    bool zero_pad_ = false;
    uint64_t produced_ = 0;
    uint64_t limit_ = std::numeric_limits<uint64_t>::max();
};

// ------------------------------------------------------------------- sinks

class Sink {
public:
    virtual ~Sink() = default;
    virtual bool write(const uint8_t* p, size_t n, std::string* err) = 0;
    virtual bool finish(std::string*) { return true; }
};

class VecSink final : public Sink {
public:
    explicit VecSink(std::vector<uint8_t>* v) : v_(v) {}
    bool write(const uint8_t* p, size_t n, std::string*) override {
        v_->insert(v_->end(), p, p + n);
        return true;
    }

private:
    std::vector<uint8_t>* v_;
};

class FdSink final : public Sink {
public:
    explicit FdSink(int fd) : fd_(fd) {}
    bool write(const uint8_t* p, size_t n, std::string* err) override {
        while (n > 0) {
            const ssize_t k = ::write(fd_, p, std::min<size_t>(n, size_t(1) << 30));
            if (k < 0) {
                if (errno == EINTR) continue;
                return fail(err, fmt("write failed: %s", std::strerror(errno)));
            }
            p += k;
            n -= size_t(k);
        }
        return true;
    }

private:
    int fd_;
};

class GzipSink final : public Sink {
public:
    // zlib_header: a zlib stream (MetaImage's CompressedData) instead of gzip.
    explicit GzipSink(Sink& out, bool zlib_header = false)
        : out_(out), buf_(size_t(1) << 16), zlib_(zlib_header) { std::memset(&zs_, 0, sizeof zs_); }
    ~GzipSink() override {
        if (inited_) deflateEnd(&zs_);
    }
    bool init(std::string* err) {
        if (deflateInit2(&zs_, 6, Z_DEFLATED, zlib_ ? 15 : 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
            return fail(err, "gzip: deflateInit2 failed");
        inited_ = true;
        return true;
    }
    bool write(const uint8_t* p, size_t n, std::string* err) override {
        while (n > 0) {
            const size_t k = std::min<size_t>(n, size_t(1) << 30);
            zs_.next_in = const_cast<uint8_t*>(p);
            zs_.avail_in = uInt(k);
            while (zs_.avail_in > 0)
                if (!pump(Z_NO_FLUSH, err)) return false;
            p += k;
            n -= k;
        }
        return true;
    }
    bool finish(std::string* err) override {
        zs_.next_in = nullptr;
        zs_.avail_in = 0;
        for (;;) {
            zs_.next_out = buf_.data();
            zs_.avail_out = uInt(buf_.size());
            const int r = deflate(&zs_, Z_FINISH);
            if (r != Z_OK && r != Z_STREAM_END && r != Z_BUF_ERROR) return fail(err, "gzip: deflate failed");
            if (!out_.write(buf_.data(), buf_.size() - zs_.avail_out, err)) return false;
            if (r == Z_STREAM_END) return out_.finish(err);
        }
    }

private:
    bool pump(int flush, std::string* err) {
        zs_.next_out = buf_.data();
        zs_.avail_out = uInt(buf_.size());
        const int r = deflate(&zs_, flush);
        if (r != Z_OK && r != Z_BUF_ERROR) return fail(err, "gzip: deflate failed");
        return out_.write(buf_.data(), buf_.size() - zs_.avail_out, err);
    }
    Sink& out_;
    std::vector<uint8_t> buf_;
    z_stream zs_;
    bool zlib_;
    bool inited_ = false;
};

// Opens `path` for reading ("cannot open 'PATH': reason" on failure).
FILE* open_for_reading(const std::string& path, std::string* err);

// Writes a file through body(sink) into a temporary file in the same
// directory, then fsyncs and renames it over `path`: a failure never leaves a
// partial file behind. With gzip the body's bytes are compressed.
bool write_file_atomic(const std::string& path, bool gzip,
                       const std::function<bool(Sink&, std::string*)>& body, std::string* err);

}  // namespace io
}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_BYTE_IO_H
