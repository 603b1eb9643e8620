/* Prints the C compiler's layout of every struct in ffseg.h, one line each:
 *   STRUCT sizeof SIZE
 *   STRUCT FIELD OFFSET SIZE
 * tests/test_abi.py compares it with the ctypes mirror in ffseg/_abi.py. */
#include <stddef.h>
#include <stdio.h>

#include "ffseg.h"

#define S(T) printf(#T " sizeof %u\n", (unsigned)sizeof(T))
#define F(T, f) printf(#T " " #f " %u %u\n", (unsigned)offsetof(T, f), (unsigned)sizeof(((T*)0)->f))

int main(void) {
  S(ffseg_config);
  F(ffseg_config, struct_size); F(ffseg_config, max_objects); F(ffseg_config, mesh_resolution);
  F(ffseg_config, reserved0); F(ffseg_config, max_roi_voxels);
  F(ffseg_config, target_mode); F(ffseg_config, reserved1);

  S(ffseg_params);
  F(ffseg_params, struct_size); F(ffseg_params, target_mode); F(ffseg_params, lambda_laplacian);
  F(ffseg_params, lambda_position); F(ffseg_params, lambda_uniform); F(ffseg_params, step_size);
  F(ffseg_params, flip_tau); F(ffseg_params, search_range_mm); F(ffseg_params, search_step_mm);
  F(ffseg_params, convergence_mm); F(ffseg_params, diffusion_iterations);
  F(ffseg_params, consecutive_background); F(ffseg_params, smoothing_iterations);
  F(ffseg_params, bin_min_count); F(ffseg_params, smoothing_kappa); F(ffseg_params, intensity_gamma);
  F(ffseg_params, sigma_floor_fraction); F(ffseg_params, bin_radius); F(ffseg_params, bin_separation);
  F(ffseg_params, partial_volume_steps); F(ffseg_params, reserved1);
  F(ffseg_params, region_width_mm); F(ffseg_params, border_weight); F(ffseg_params, region_interval);
  F(ffseg_params, reserved2);

  S(ffseg_volume);
  F(ffseg_volume, struct_size); F(ffseg_volume, voxel_type); F(ffseg_volume, data);
  F(ffseg_volume, data_bytes); F(ffseg_volume, offset); F(ffseg_volume, dims); F(ffseg_volume, strides);
  F(ffseg_volume, index_to_world); F(ffseg_volume, rescale_slope); F(ffseg_volume, rescale_intercept);

  S(ffseg_step_info);
  F(ffseg_step_info, struct_size); F(ffseg_step_info, step_index); F(ffseg_step_info, active_objects);
  F(ffseg_step_info, reserved0); F(ffseg_step_info, mean_displacement_mm);
  F(ffseg_step_info, vertices_with_target); F(ffseg_step_info, flips_avoided);
  F(ffseg_step_info, intersections_avoided); F(ffseg_step_info, border_vertices);
  F(ffseg_step_info, stage_us); F(ffseg_step_info, object_flags); F(ffseg_step_info, flags_all);
  F(ffseg_step_info, reserved1); F(ffseg_step_info, guard_held); F(ffseg_step_info, far_outward);
  F(ffseg_step_info, far_inward);

  /* Constants the mirror repeats. */
  printf("const FFSEG_STAGE_COUNT %d\n", FFSEG_STAGE_COUNT);
  printf("const FFSEG_REPORT_OBJECTS %d\n", FFSEG_REPORT_OBJECTS);
  printf("const FFSEG_TARGET_BINARY %d\n", FFSEG_TARGET_BINARY);
  printf("const FFSEG_TARGET_INTENSITY %d\n", FFSEG_TARGET_INTENSITY);
  printf("const FFSEG_CONVERGED %d\n", FFSEG_CONVERGED);
  printf("const FFSEG_DEGENERATE %d\n", FFSEG_DEGENERATE);
  printf("const FFSEG_OBJECT_NO_BOUNDARY %u\nconst FFSEG_OBJECT_FILLS_GRID %u\n", FFSEG_OBJECT_NO_BOUNDARY,
         FFSEG_OBJECT_FILLS_GRID);
  printf("const FFSEG_U8 %d\nconst FFSEG_I16 %d\nconst FFSEG_U16 %d\n", FFSEG_U8, FFSEG_I16, FFSEG_U16);
  printf("const FFSEG_I32 %d\nconst FFSEG_F32 %d\nconst FFSEG_F64 %d\n", FFSEG_I32, FFSEG_F32, FFSEG_F64);
  return 0;
}
