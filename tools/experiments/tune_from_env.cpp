#include "tune_from_env.h"

#include <cstdint>
#include <cstdlib>

namespace ffseg_experiments {

void tune_from_env(ffseg_params& p) {
  if (const char* e = std::getenv("FFSEG_SIGF")) p.sigma_floor_fraction = std::atof(e);
  if (const char* e = std::getenv("FFSEG_GAMMA")) p.intensity_gamma = std::atof(e);
  if (const char* e = std::getenv("FFSEG_SR")) p.search_range_mm = std::atof(e);
  if (const char* e = std::getenv("FFSEG_ALPHA")) p.step_size = std::atof(e);
  if (const char* e = std::getenv("FFSEG_SMI")) p.smoothing_iterations = uint32_t(std::atoi(e));
  if (const char* e = std::getenv("FFSEG_NB")) p.consecutive_background = uint32_t(std::atoi(e));
  if (const char* e = std::getenv("FFSEG_DIFF")) p.diffusion_iterations = uint32_t(std::atoi(e));
  if (const char* e = std::getenv("FFSEG_LL")) p.lambda_laplacian = std::atof(e);
  if (const char* e = std::getenv("FFSEG_LU")) p.lambda_uniform = std::atof(e);
  if (const char* e = std::getenv("FFSEG_LP")) p.lambda_position = std::atof(e);
  if (const char* e = std::getenv("FFSEG_TAU")) p.flip_tau = std::atof(e);
  if (const char* e = std::getenv("FFSEG_CONV")) p.convergence_mm = std::atof(e);
  if (const char* e = std::getenv("FFSEG_PVS")) p.partial_volume_steps = uint32_t(std::atoi(e));
}

}  // namespace ffseg_experiments
