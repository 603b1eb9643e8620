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
#ifndef FFSEG_CLI_REFINEMENT_REACH_H
#define FFSEG_CLI_REFINEMENT_REACH_H

#include <cstdint>
#include <vector>

namespace ffseg_cli {

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
