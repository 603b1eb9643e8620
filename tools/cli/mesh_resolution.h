// The mesh resolution `ffseg segment` picks when --mesh-resolution is not
// given: from the size the surface reaches, not one number for every organ.
//
// A first run at kFirstResolution shows how large each object becomes; the
// resolution that gives its surface quads of about kEdgeVoxels voxel spacings
// a side follows from its area A (6 n^2 quads): n = ceil(sqrt(A / 6) / h).
// When the largest object asks for more than kRerunFactor times the first
// resolution, the run is made again at that resolution from the first run's
// meshes (coarse to fine, cmd_segment.cpp run_engine_once);
// else the first run stands (and goes on to rest if it was measured before). Small structures (Colin27's deep nuclei, 8 ml)
// ask for 13-15 and keep the first run, which is also among the best fixed
// resolutions there (BENCHMARKS.md section 4, 2026-12-04: mean Dice 0.542 at
// n = 12, 0.543 at 14, 0.531-0.540 at 8, 10, 16, 20, 24, 33; mean ASSD 3.17 mm
// at 12, the lowest); the Colin27 brain (ch2bet) asks for
// more than the cap, 49, the resolution of its chapter-4 test (Dice 0.988).
#ifndef FFSEG_CLI_MESH_RESOLUTION_H
#define FFSEG_CLI_MESH_RESOLUTION_H

#include <cstddef>
#include <cstdint>
#include <vector>

namespace ffseg_cli {

constexpr uint32_t kFirstResolution = 12;
constexpr uint32_t kMaxAutoResolution = 49;
constexpr double kEdgeVoxels = 1.5;
constexpr double kRerunFactor = 1.5;
// The first run is measured at rest (or at --max-steps), so that the finer
// run refines a converged coarse mesh (issue 29); it was measured after 60
// steps once, and the 1 mm CT's liver, refined from where its n = 12 mesh
// had got to then, ended short of the n = 12 run (BENCHMARKS section 12).

// A mesh that grew freely along a tube or a horn (grey_respacing) has
// re-spaced its loops along the growth, so its quads are stretched there: its
// area understates the resolution the stretched part needs (the grey tube
// phantom at 1 mm, n = 12 at 74% of its length: the area asks for 15, its
// edges along the tube are 4-5 voxels). For such an object the resolution
// also follows from its long edges: the kStretchQuantile quantile of its quad
// sides, made kEdgeVoxels voxel spacings at the finer n. Chosen on Colin27's
// left lateral ventricle (BENCHMARKS.md section 12).
constexpr double kStretchQuantile = 0.75;

// Area (mm^2) of a triangle mesh: xyz 3 floats per vertex, tris 3 indices each.
double mesh_area_mm2(const std::vector<float>& xyz, const std::vector<uint32_t>& tris);
// The quad sides of a triangle mesh made of split quads, two per triangle
// in triangle order: each triangle's two shorter edges, the shorter first.
std::vector<double> quad_sides_mm(const std::vector<float>& xyz, const std::vector<uint32_t>& tris);
// The q quantile (0..1) of the quad sides of a triangle mesh made of split
// quads: each triangle's two shorter edges (the longest is the quad's
// diagonal, or a side shared with a triangle that counts it). 0 for no triangle.
double quad_side_quantile_mm(const std::vector<float>& xyz, const std::vector<uint32_t>& tris, double q);
// The resolution at which sides of side_mm on a mesh of resolution n_now
// become kEdgeVoxels * spacing_mm, within [kFirstResolution, kMaxAutoResolution].
uint32_t resolution_for_sides(double side_mm, uint32_t n_now, double spacing_mm);
// The resolution whose quads on a surface of area_mm2 are kEdgeVoxels *
// spacing_mm a side, within [kFirstResolution, kMaxAutoResolution].
uint32_t resolution_for_area(double area_mm2, double spacing_mm);
// The resolution to run again at after the first run, or 0 to keep it.
uint32_t rerun_resolution(uint32_t wanted);

}  // namespace ffseg_cli

#endif
