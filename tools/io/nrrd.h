// ffseg tools: strict NRRD reader (.nrrd with attached data, .nhdr with a
// detached data file) and writer, from the NRRD file format description
// (NRRD0001-NRRD0005 headers).
//
// Policy:
//  * 3-D scalar images only: dimension 3, every axis spatial (kinds domain or
//    space, if given). Types: the integer and float types (block refused);
//    int8 is widened to int16, uint32 / int64 / uint64 to float64 as in nifti.h.
//  * Encodings raw and gzip (gz); ascii/text, hex and bzip2 are refused.
//    endian is required for multi-byte types.
//  * Geometry: space (right-anterior-superior, left-anterior-superior,
//    left-posterior-superior or their RAS / LAS / LPS abbreviations), space
//    directions and space origin (the centre of the first voxel); LAS and LPS
//    are converted to the tools' RAS frame (image_common.h). Without space,
//    spacings give a diagonal affine; with neither, 1 mm voxels. space units,
//    if given, must be mm. Spaces without an anatomical frame (scanner-xyz,
//    3D-right-handed, space dimension) and time spaces are refused.
//  * Detached data: one data file (relative to the header's directory; LIST
//    and file-name patterns are refused), line skip, byte skip (-1 = the data
//    ends the file; raw only). Unknown fields are refused with their name;
//    key:=value pairs and comments are skipped; a field given twice is refused.
//  * Every error names the field (or the line) it comes from.
#ifndef FFSEG_TOOLS_NRRD_H
#define FFSEG_TOOLS_NRRD_H

#include <cstddef>
#include <cstdint>
#include <string>

#include "nifti.h"

namespace ffseg_tools {

bool nrrd_read_file(const std::string& path, NiftiImage* out, std::string* err, const NiftiLimits& lim = {});
// A .nrrd in memory (attached data only: a header naming a data file is refused).
bool nrrd_read_memory(const uint8_t* data, size_t size, NiftiImage* out, std::string* err,
                      const NiftiLimits& lim = {});

// Writes NRRD0004 with attached gzip data, space left-posterior-superior,
// space directions and origin exact to the last bit ("%.17g"), through a
// temporary file renamed into place. `path` must end in .nrrd.
bool nrrd_write_file(const std::string& path, const NiftiImage& img, std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_NRRD_H
