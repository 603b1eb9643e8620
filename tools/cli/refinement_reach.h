// How far a finer run may grow from the first run's surface and still be a
// refinement of it (cmd_segment.cpp, run_engine_once).
//
// The finer run starts from the first run's meshes at rest. Its loops
// re-space (grey_respacing) so that its vertices spread into the corners,
// lobes and horns the coarse mesh jammed short of: the liver of the shared CT
// at 3 mm enters its left lobe (Dice 0.849 -> 0.900, ASSD 4.3 -> 2.3 mm).
// What a coarse mesh can leave out is at most a shell one of its cells thick
// over its surface: its area times its mean quad side (the liver at n = 12:
// 8.8 mm). A finer run that encloses more than the first run's volume plus
// that shell has gone beyond what the coarse mesh could have missed: the
// re-spacing has carried it through a gap into a neighbour of its grey level
// (the 1 mm CT's gallbladder, 40 -> 182 ml; the aorta, the vena cava), the
// leak free growth makes of an organ whose boundary is not in view
// (intensity_model.h). The finer run is then made again without re-spacing,
// as it was before, so no object ends where the leak took it.
//
// Where the first run's resolution is kept, the re-spaced pass at it that
// leaves its reach tells the same: the object's grey level goes on past the
// surface its first run rested at, and the first run, which crept along the
// same way until its rest rules stopped it, has likely leaked too (the 3 mm
// CT's gallbladder 161 ml of 35, vena cava 87 of 58, aorta 69 of 48). Such
// an object is run once more from its sphere at kLeakerResolution, a mesh
// whose quads are twice as wide (the first run's mesh is this one with each
// cell split into four): it cannot follow a passage as narrow, and it
// creeps half as far in a step of the same relative size. Of the two runs
// the one that encloses fewer voxels stands; a run that stalls or finds no
// boundary is no candidate. Chosen on the choosing set of the shared CT
// (BENCHMARKS.md section 12, sixteenth session).
#ifndef FFSEG_CLI_REFINEMENT_REACH_H
#define FFSEG_CLI_REFINEMENT_REACH_H

#include <cstdint>
#include <vector>

namespace ffseg_cli {

// The resolution a leaker's first run is made again at (see above): half
// the first run's (mesh_resolution.h: kFirstResolution = 12).
constexpr uint32_t kLeakerResolution = 6;

// Volume (mm^3) a closed, outward-oriented triangle mesh encloses
// (divergence theorem): xyz 3 floats per vertex, tris 3 indices each.
double enclosed_volume_mm3(const std::vector<float>& xyz, const std::vector<uint32_t>& tris);
// The mean quad side of a mesh of split quads (each triangle's two shorter
// edges; mesh_resolution.h's quad sides); 0 for no triangle.
double mean_quad_side_mm(const std::vector<float>& xyz, const std::vector<uint32_t>& tris);
// The most a finer run from this first-run mesh may enclose and still be a
// refinement of it: its volume plus its area times its mean quad side.
double refinement_reach_mm3(const std::vector<float>& xyz, const std::vector<uint32_t>& tris);

}  // namespace ffseg_cli

#endif
