/* ffseg_fields.h - every field of every public struct of ffseg.h, in declaration
 * order, as X-macros. One list for the three places that check the layout: the
 * no-padding unit test (tests/capi/test_abi_layout.cpp), and layout.c, the program
 * whose output the Rust and C# bindings compare their own layouts against.
 * Appending a field to a struct in ffseg.h without appending it here fails the
 * unit test (the listed sizes no longer add up to sizeof). */
#ifndef FFSEG_FIELDS_H
#define FFSEG_FIELDS_H

#define FFSEG_CONFIG_FIELDS(F)                                                            \
  F(ffseg_config, struct_size) F(ffseg_config, max_objects) F(ffseg_config, mesh_resolution) \
  F(ffseg_config, reserved0) F(ffseg_config, max_roi_voxels) F(ffseg_config, target_mode)   \
  F(ffseg_config, reserved1) F(ffseg_config, max_region_voxels)

#define FFSEG_PARAMS_FIELDS(F)                                                            \
  F(ffseg_params, struct_size) F(ffseg_params, target_mode) F(ffseg_params, lambda_laplacian) \
  F(ffseg_params, lambda_position) F(ffseg_params, lambda_uniform) F(ffseg_params, step_size) \
  F(ffseg_params, flip_tau) F(ffseg_params, search_range_mm) F(ffseg_params, search_step_mm) \
  F(ffseg_params, convergence_mm) F(ffseg_params, diffusion_iterations)                     \
  F(ffseg_params, consecutive_background) F(ffseg_params, smoothing_iterations)             \
  F(ffseg_params, bin_min_count) F(ffseg_params, smoothing_kappa)                           \
  F(ffseg_params, intensity_gamma) F(ffseg_params, sigma_floor_fraction)                    \
  F(ffseg_params, bin_radius) F(ffseg_params, bin_separation)                               \
  F(ffseg_params, partial_volume_steps) F(ffseg_params, reserved1)                         \
  F(ffseg_params, region_width_mm) F(ffseg_params, border_weight)                           \
  F(ffseg_params, region_interval) F(ffseg_params, grey_respacing)

#define FFSEG_VOLUME_FIELDS(F)                                                            \
  F(ffseg_volume, struct_size) F(ffseg_volume, voxel_type) F(ffseg_volume, data)            \
  F(ffseg_volume, data_bytes) F(ffseg_volume, offset) F(ffseg_volume, dims)                 \
  F(ffseg_volume, strides) F(ffseg_volume, index_to_world) F(ffseg_volume, rescale_slope)   \
  F(ffseg_volume, rescale_intercept)

#define FFSEG_STEP_INFO_FIELDS(F)                                                         \
  F(ffseg_step_info, struct_size) F(ffseg_step_info, step_index)                            \
  F(ffseg_step_info, active_objects) F(ffseg_step_info, reserved0)                          \
  F(ffseg_step_info, mean_displacement_mm) F(ffseg_step_info, vertices_with_target)         \
  F(ffseg_step_info, flips_avoided) F(ffseg_step_info, intersections_avoided)               \
  F(ffseg_step_info, border_vertices) F(ffseg_step_info, stage_us)                         \
  F(ffseg_step_info, object_flags) F(ffseg_step_info, flags_all) F(ffseg_step_info, reserved1)   \
  F(ffseg_step_info, guard_held) F(ffseg_step_info, far_outward) F(ffseg_step_info, far_inward) \
  F(ffseg_step_info, respaced)

/* S(struct, FIELDS-macro) for each public struct. */
#define FFSEG_PUBLIC_STRUCTS(S)                                                           \
  S(ffseg_config, FFSEG_CONFIG_FIELDS) S(ffseg_params, FFSEG_PARAMS_FIELDS)                 \
  S(ffseg_volume, FFSEG_VOLUME_FIELDS) S(ffseg_step_info, FFSEG_STEP_INFO_FIELDS)

#endif /* FFSEG_FIELDS_H */
