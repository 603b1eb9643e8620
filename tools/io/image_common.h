// ffseg tools: what the text-header readers (NRRD, MetaImage) and the DICOM
// reader share: the scalar types they accept and how they become the tools'
// in-memory image (NiftiImage), the LPS <-> RAS world frames, strict number
// parsing, and the voxel block reader.
//
// The tools' world frame is NIfTI's, RAS (+x towards the patient's right,
// +y anterior, +z superior).
// NRRD (space left-posterior-superior), MetaImage and DICOM store LPS; their
// readers negate x and y on the way in and their writers on the way out, so a
// --sphere centre, a mesh and a report mean the same point whatever the file.
#ifndef FFSEG_TOOLS_IMAGE_COMMON_H
#define FFSEG_TOOLS_IMAGE_COMMON_H

#include <cstdint>
#include <string>
#include <vector>

#include "byte_io.h"
#include "nifti.h"

namespace ffseg_tools {
namespace img {

using io::Source;

// A stored scalar type and what it becomes in NiftiImage::data (the NIfTI
// reader's rules: int8 widened to int16, uint32 / int64 / uint64 to float64).
struct ScalarType {
    const char* name;      // "uint8", "int16", ...
    int file_bytes;
    int voxel_type;        // kNiftiVox*
    int out_bytes;
    int nifti_datatype;    // kNiftiDt* of the stored type (for reports)
};
const ScalarType* scalar_type_by_name(const std::string& name);       // "uint8", "int16", ...
const ScalarType* scalar_type_of_voxel_type(int voxel_type);          // the six engine types

// Reads dims[0] * dims[1] * dims[2] voxels of type t from src (big_endian:
// the file's byte order) into img->data, converted to native order and the
// engine type; the buffer grows only as bytes arrive, never beyond
// lim.max_bytes. `what` names the data for messages ("data file 'x.raw'").
bool read_voxels(Source& src, const ScalarType& t, bool big_endian, const int dims[3],
                 const NiftiLimits& lim, NiftiImage* img, const std::string& what, std::string* err);

// Fills the geometry of *img from an LPS index-to-world (columns = the three
// axis steps in mm, origin = the centre of voxel 0): validates finiteness and
// non-singularity (message names `field`), converts to RAS, sets spacing,
// pixdim, which_affine = source.
bool set_lps_geometry(const double axis[3][3], const double origin[3], NiftiImage* img,
                      const char* source, const char* field, std::string* err);
// The inverse: the LPS axis steps and origin of img's RAS affine.
void lps_geometry(const NiftiImage& img, double axis[3][3], double origin[3]);

// Strict numbers: the whole token, finite. Integers: the whole token, in range.
bool parse_double(const std::string& tok, double* v);
bool parse_int64(const std::string& tok, int64_t lo, int64_t hi, int64_t* v);
std::vector<std::string> split_ws(const std::string& s);
std::string trim(const std::string& s);
std::string lower(std::string s);
// "%.17g": reads back to the same double.
std::string exact(double v);

// Directory part of a path ("" for a bare name), and a path joined to it
// unless absolute.
std::string dir_of(const std::string& path);
std::string resolve_beside(const std::string& header_path, const std::string& name);

bool host_is_big_endian();

// Header lines of a text header (NRRD, MetaImage), read one at a time from
// a file or from memory: "\n" ends a line (a "\r" before it is dropped); a
// line longer than 64 KiB, a NUL byte or more than 1 MiB of header is an error.
class LineSource {
public:
    virtual ~LineSource() = default;
    // *end: the input ended before any byte of a line.
    bool next(std::string* line, bool* end, std::string* err);
    size_t header_bytes() const { return total_; }

protected:
    virtual int get() = 0;  // next byte or -1 at the end

private:
    size_t total_ = 0;
};

class FileLines final : public LineSource {
public:
    explicit FileLines(FILE* f) : f_(f) {}

protected:
    int get() override { return std::getc(f_); }

private:
    FILE* f_;
};

class MemLines final : public LineSource {
public:
    MemLines(const uint8_t* p, size_t n) : p_(p), n_(n) {}
    size_t pos() const { return pos_; }

protected:
    int get() override { return pos_ < n_ ? p_[pos_++] : -1; }

private:
    const uint8_t* p_;
    size_t n_, pos_ = 0;
};

}  // namespace img
}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_IMAGE_COMMON_H
