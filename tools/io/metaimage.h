// ffseg tools: strict MetaImage reader (.mha with local data, .mhd with a
// raw data file beside it) and writer, from the MetaIO description.
//
// Policy:
//  * ObjectType Image, NDims 3, one channel; ElementType MET_UCHAR, MET_CHAR,
//    MET_SHORT, MET_USHORT, MET_INT, MET_UINT, MET_LONG, MET_ULONG (4 bytes),
//    MET_LONG_LONG, MET_ULONG_LONG, MET_FLOAT, MET_DOUBLE (widened as nifti.h
//    says). BinaryData must be True (ASCII data is refused).
//  * Geometry: TransformMatrix (alias Rotation, Orientation; nine numbers, the
//    i axis' direction first, then j's, then k's), Offset (alias Origin,
//    Position; the centre of the first voxel), ElementSpacing; in ITK's LPS
//    frame, converted to the tools' RAS frame. Missing: identity, 0, 1 mm.
//  * CompressedData True: zlib (or gzip) data, bounded; CompressedDataSize,
//    if given, is checked. BinaryDataByteOrderMSB (alias ElementByteOrderMSB)
//    gives the byte order.
//  * ElementDataFile (LOCAL or one file beside the header; LIST and patterns
//    are refused) ends the header. HeaderSize skips bytes of a data file
//    (-1: the data ends it; uncompressed only).
//  * The fields above are checked and an error names the field; other fields
//    (Comment, Modality, ITK's metadata entries, ...) are allowed by the
//    format and skipped. A field given twice is refused.
#ifndef FFSEG_TOOLS_METAIMAGE_H
#define FFSEG_TOOLS_METAIMAGE_H

#include <cstddef>
#include <cstdint>
#include <string>

#include "nifti.h"

namespace ffseg_tools {

bool metaimage_read_file(const std::string& path, NiftiImage* out, std::string* err,
                         const NiftiLimits& lim = {});
// A .mha in memory (ElementDataFile = LOCAL only).
bool metaimage_read_memory(const uint8_t* data, size_t size, NiftiImage* out, std::string* err,
                           const NiftiLimits& lim = {});

// Writes a .mha (local zlib-compressed data, LPS TransformMatrix / Offset /
// ElementSpacing at "%.17g") through a temporary file renamed into place.
bool metaimage_write_file(const std::string& path, const NiftiImage& img, std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_METAIMAGE_H
