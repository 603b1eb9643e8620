// Triangle-mesh files for the ffseg tools (never linked into the core).
//
// Writers for the four formats the command-line tool offers, and readers good
// enough to read back what the writers produce (used by the tests and by
// anyone checking an output):
//   ply  binary little-endian PLY 1.0: float x y z per vertex, faces as
//        "list uchar int vertex_indices" (the default);
//   stl  binary STL: 80-byte header, uint32 count, per triangle a unit normal
//        and three vertices (float32 little endian), uint16 attribute 0.
//        STL has no shared vertices: reading one back gives 3 per triangle;
//   obj  Wavefront OBJ text: "v x y z" lines, then "f a b c" (1-based);
//   vtk  legacy VTK 3.0 ASCII POLYDATA: POINTS float, POLYGONS 3 a b c.
// Coordinates are written as given (ffseg: world millimetres). Every writer
// takes a `comment` (one line, e.g. "SPACE=RAS"), written where the format has
// room for one: the PLY comment line, the STL header, an OBJ "#" line, the VTK
// title line. Triangles are written in the order and orientation given.
#ifndef FFSEG_TOOLS_MESH_IO_H
#define FFSEG_TOOLS_MESH_IO_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ffseg_tools {

enum class MeshFormat { Ply, Stl, Obj, Vtk };

// "ply", "stl", "obj", "vtk" (case-insensitive) -> format; false otherwise.
bool mesh_format_from_name(const std::string& name, MeshFormat* out);
// The file extension without the dot: "ply", "stl", "obj", "vtk".
const char* mesh_format_extension(MeshFormat f);

struct MeshData {
  std::vector<float> xyz;      // 3 per vertex
  std::vector<uint32_t> tris;  // 3 per triangle
  std::string comment;         // what the file's comment slot held (trimmed)
  size_t vertex_count() const { return xyz.size() / 3; }
  size_t triangle_count() const { return tris.size() / 3; }
};

// Encodes a mesh into bytes. Fails (false, *err set) when an index is out of
// range or a count does not fit the format (PLY/STL counts are 32-bit).
bool mesh_encode(MeshFormat f, const float* xyz, size_t n_vertices, const uint32_t* tris,
                 size_t n_tris, const std::string& comment, std::vector<uint8_t>* out,
                 std::string* err);

// Writes the encoded mesh to `path` (plain write; callers wanting atomicity
// write into a temporary directory). false with *err on an I/O failure.
bool mesh_write_file(const std::string& path, MeshFormat f, const float* xyz, size_t n_vertices,
                     const uint32_t* tris, size_t n_tris, const std::string& comment,
                     std::string* err);

// Parses a mesh in the given format. Only what the writers produce is promised
// (plus ASCII/big-endian variants are refused with a message, not misread);
// triangles only. false with *err on anything malformed.
bool mesh_decode(MeshFormat f, const uint8_t* data, size_t size, MeshData* out, std::string* err);
bool mesh_read_file(const std::string& path, MeshFormat f, MeshData* out, std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_MESH_IO_H
