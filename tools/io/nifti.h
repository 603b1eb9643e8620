// ffseg tools: strict NIfTI-1 (single file, .nii / .nii.gz) reader and writer.
//
// This is tool-side code (file I/O); the core engine never links it.
// Written from the NIfTI-1 format description; no code from nifti1_io.
//
// Policy summary (details in nifti.cpp, next to each check):
//  * Only single-file NIfTI-1 ("n+1\0") is accepted.  "ni1\0" (.hdr/.img
//    pair), NIfTI-2 (sizeof_hdr 540, magic "n+2\0") and ANALYZE 7.5 are
//    refused with a message that says so.
//  * Either byte order (detected from sizeof_hdr == 348 or its byte swap);
//    header and voxels are returned in native order.
//  * 3D only: dim[0] in 1..7, dim[1..dim[0]] > 0, dim[4..dim[0]] must be 1.
//  * Voxels are returned exactly as stored (scl_slope/scl_inter are reported,
//    never applied).  int8 is widened to int16, uint32/int64/uint64 to
//    float64 (int64/uint64 are exact only up to 2^53 in magnitude).
//  * Affine: sform if sform_code > 0, else qform if qform_code > 0, else
//    diag(pixdim[1..3]) (NIfTI "method 1").
//  * Every transform whose code is > 0 is validated, even if not the one used.
//  * pixdim[1..3] must always be finite.  They must be > 0 when the qform or
//    the pixdim fallback is used (the voxel size is then taken from them; the
//    sign of the 3rd axis lives in qfac = pixdim[0], so a negative pixdim has
//    no defined meaning in NIfTI-1 and is refused).  When the sform is used,
//    pixdim[1..3] may be zero or negative (they are informational only); the
//    reported spacing is then the column norms of the sform.
//  * gzip input is detected from its magic bytes (not from the file name),
//    inflated in a streaming way, and bounded: never more than
//    min(max_bytes, vox_offset + data bytes + slack_bytes) bytes are produced;
//    a bigger stream is refused.  The stream must end properly (CRC checked);
//    truncated or corrupt gzip is an error.  Concatenated gzip members and
//    trailing zero padding are accepted.  While the stream is read, the voxel
//    buffer grows only as data really arrives, so a lying header cannot make
//    the reader allocate much more than the input actually decompresses to.
//  * Uncompressed input: bytes after the voxel data are ignored; a file too
//    short for vox_offset + data is refused before the buffer is allocated.
//  * vox_offset must be an integer >= 352 (multiple of 16 is not enforced);
//    extension blocks between 348 and vox_offset are skipped, not parsed.
//  * qfac: the sign of pixdim[0] (0 -> +1); it must be finite if the qform is
//    used.  The quaternion needs b^2+c^2+d^2 <= 1 + 1e-5.  The sform must be
//    finite and non-singular (|det| > 1e-6 * product of column norms).
//  * qform_code / sform_code must be in 0..5.
//  * scl_slope == 0 means "no scaling" (reported as slope 1, intercept 0);
//    NaN/Inf slope or intercept is an error (even when slope is 0).
#ifndef FFSEG_TOOLS_NIFTI_H
#define FFSEG_TOOLS_NIFTI_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ffseg_tools {

// Engine voxel type codes.  Identical values to FFSEG_U8 .. FFSEG_F64 in
// include/ffseg.h (FFSEG_U8=1, FFSEG_I16=2, FFSEG_U16=3, FFSEG_I32=4,
// FFSEG_F32=5, FFSEG_F64=6); duplicated here so the tools header does not
// depend on the engine header.
enum : int {
    kNiftiVoxU8 = 1,
    kNiftiVoxI16 = 2,
    kNiftiVoxU16 = 3,
    kNiftiVoxI32 = 4,
    kNiftiVoxF32 = 5,
    kNiftiVoxF64 = 6,
};

// NIfTI-1 datatype codes (the header's "datatype" field).
enum : int {
    kNiftiDtUint8 = 2,
    kNiftiDtInt16 = 4,
    kNiftiDtInt32 = 8,
    kNiftiDtFloat32 = 16,
    kNiftiDtFloat64 = 64,
    kNiftiDtInt8 = 256,
    kNiftiDtUint16 = 512,
    kNiftiDtUint32 = 768,
    kNiftiDtInt64 = 1024,
    kNiftiDtUint64 = 1280,
};

constexpr int kNiftiIntentLabel = 1002;  // NIFTI_INTENT_LABEL
constexpr size_t kNiftiHeaderSize = 348;

struct NiftiLimits {
    // Hard bound on bytes produced while reading (vox_offset + voxel data,
    // and also the size of the output voxel buffer).  Default 4 GiB.
    uint64_t max_bytes = uint64_t(4) << 30;
    // gzip only: bytes tolerated after the voxel data before the gzip stream
    // must end.  Anything longer is refused (decompression-bomb guard).
    uint64_t slack_bytes = uint64_t(64) << 10;
};

struct NiftiImage {
    int dims[3] = {0, 0, 0};          // voxels along i, j, k
    int voxel_type = 0;               // kNiftiVox* (== FFSEG_* engine codes)
    int bytes_per_voxel = 0;          // of `data` (after widening)
    std::vector<uint8_t> data;        // native endian, i fastest, then j, k

    double index_to_world[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
                                      // row-major 4x4: voxel index -> mm
    std::string which_affine = "pixdim";  // "sform", "qform" or "pixdim"
    double pixdim[8] = {1, 1, 1, 1, 0, 0, 0, 0};  // raw header pixdim[0..7]
    double spacing[3] = {1, 1, 1};    // mm per voxel along i, j, k (see top)
    double scl_slope = 1.0;           // 1/0 when the header says "no scaling"
    double scl_inter = 0.0;
    int sform_code = 0;
    int qform_code = 0;
    int intent_code = 0;
    int datatype = 0;                 // original NIfTI datatype code
    int xyzt_units = 0;
    std::string descrip;              // up to 79 chars
    std::vector<uint8_t> raw_header;  // the 348 header bytes as read, in
                                      // native byte order (empty if built in
                                      // memory); kept for provenance

    uint64_t voxel_count() const {
        return uint64_t(dims[0] > 0 ? dims[0] : 0) * uint64_t(dims[1] > 0 ? dims[1] : 0) *
               uint64_t(dims[2] > 0 ? dims[2] : 0);
    }
};

// Readers.  On failure return false, set *err (if non-null) to a specific
// message, and leave *out in an unspecified but valid state.
bool nifti_read_file(const std::string& path, NiftiImage* out, std::string* err,
                     const NiftiLimits& lim = {});
bool nifti_read_memory(const uint8_t* data, size_t size, NiftiImage* out, std::string* err,
                       const NiftiLimits& lim = {});

// Bytes per voxel of an engine voxel type (0 if unknown) and its NIfTI
// datatype code (0 if unknown).
int nifti_voxel_type_size(int voxel_type);
int nifti_datatype_for_voxel_type(int voxel_type);

// Encode an image as a complete single-file NIfTI-1 (vox_offset 352, native
// byte order), optionally gzip-compressed.  Both sform and qform are set from
// index_to_world (qform: nearest rotation, qfac = -1 if the matrix has a
// reflection).  Codes: sform_code = img.sform_code if > 0, else
// img.qform_code if > 0, else 2 (aligned anatomy); qform_code likewise with
// the roles swapped.
bool nifti_encode(const NiftiImage& img, bool gzip, std::vector<uint8_t>* out, std::string* err);

// Write .nii or .nii.gz (chosen by the file extension, case-insensitive).
// Writes a temporary file in the same directory and renames it over `path`,
// so a failure never leaves a partial file behind.
bool nifti_write_file(const std::string& path, const NiftiImage& img, std::string* err);

// A zero-filled label image with the geometry (dims, affine, codes, pixdim,
// units) of `ref`.  voxel_type defaults to uint8; intent is NIFTI_INTENT_LABEL.
NiftiImage nifti_make_label_image(const NiftiImage& ref, int voxel_type = kNiftiVoxU8);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_NIFTI_H
