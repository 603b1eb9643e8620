/* grow.c - a real segmentation through the C API: a small sphere placed inside
 * an ellipsoid is stepped until it has grown onto the ellipsoid's surface, then
 * rasterized and compared with the ellipsoid voxel by voxel (Dice). Plain C99.
 * Exits 0 only if the run converged and Dice >= 0.9. */
#include <stdio.h>
#include <stdlib.h>

#include "ffseg.h"

enum { NX = 64, NY = 56, NZ = 40 };

int main(void) {
  /* The object: an ellipsoid, semi-axes 20 x 14 x 12 mm, on 1 x 1 x 1.5 mm voxels. */
  const double spacing[3] = {1.0, 1.0, 1.5};
  const double centre[3] = {32.0, 28.0, 30.0}, axes[3] = {20.0, 14.0, 12.0};
  const size_t nvox = (size_t)NX * NY * NZ;
  uint8_t* voxels = (uint8_t*)malloc(nvox);
  uint8_t* mask = (uint8_t*)malloc(nvox);
  ffseg_config cfg;
  ffseg_params params;
  ffseg_volume vol = {0};
  ffseg_step_info info;
  ffseg_engine* e = NULL;
  ffseg_status st = FFSEG_OK;
  size_t bytes = 0, i, truth = 0, found = 0, both = 0;
  void* raw;
  void* ws;
  int x, y, z, steps = 0;
  double dice;

  if (!voxels || !mask) return 1;
  for (z = 0; z < NZ; ++z)
    for (y = 0; y < NY; ++y)
      for (x = 0; x < NX; ++x) {
        const double p[3] = {x * spacing[0], y * spacing[1], z * spacing[2]};
        double r2 = 0.0;
        int a;
        for (a = 0; a < 3; ++a) r2 += (p[a] - centre[a]) * (p[a] - centre[a]) / (axes[a] * axes[a]);
        voxels[(size_t)x + NX * ((size_t)y + (size_t)NY * z)] = r2 <= 1.0;
      }

  ffseg_config_init_default(&cfg);
  cfg.mesh_resolution = 16;
  if (ffseg_workspace_size(&cfg, &bytes) != FFSEG_OK) {
    fprintf(stderr, "workspace_size: %s\n", ffseg_last_error(NULL));
    return 1;
  }
  raw = malloc(bytes + 63);
  if (raw == NULL) return 1;
  ws = (void*)(((uintptr_t)raw + 63) & ~(uintptr_t)63);
  if (ffseg_create(&cfg, ws, bytes, &e) != FFSEG_OK) {
    fprintf(stderr, "create: %s\n", ffseg_last_error(NULL));
    return 1;
  }

  vol.struct_size = sizeof vol;
  vol.voxel_type = FFSEG_U8;
  vol.data = voxels;
  vol.data_bytes = nvox;
  vol.dims[0] = NX; vol.dims[1] = NY; vol.dims[2] = NZ;
  vol.strides[0] = 1; vol.strides[1] = NX; vol.strides[2] = (int64_t)NX * NY;
  vol.index_to_world[0] = spacing[0];
  vol.index_to_world[5] = spacing[1];
  vol.index_to_world[10] = spacing[2];
  vol.index_to_world[15] = 1.0;
  vol.rescale_slope = 1.0;
  ffseg_params_init_default(&params);
  params.target_mode = FFSEG_TARGET_BINARY;
  if (ffseg_set_volume(e, &vol) != FFSEG_OK || ffseg_set_params(e, &params) != FFSEG_OK ||
      ffseg_init_sphere(e, 0, centre, 5.0) != FFSEG_OK) {
    fprintf(stderr, "setup: %s\n", ffseg_last_error(e));
    return 1;
  }
  info.struct_size = sizeof info;
  while (steps < 300 && (st = ffseg_step(e, &info)) == FFSEG_OK) ++steps;
  if (st < 0) {
    fprintf(stderr, "step %d: %s (%s)\n", steps, ffseg_status_string(st), ffseg_last_error(e));
    return 1;
  }
  if (ffseg_rasterize(e, 0, mask, NULL) != FFSEG_OK) return 1;
  for (i = 0; i < nvox; ++i) {
    truth += voxels[i];
    found += mask[i];
    both += voxels[i] & mask[i];
  }
  dice = 2.0 * (double)both / (double)(truth + found);
  printf("grow (C): %s after %u steps, %zu voxels found, %zu in the ellipsoid, Dice %.3f\n",
         st == FFSEG_CONVERGED ? "converged" : "not converged", info.step_index, found, truth, dice);
  ffseg_destroy(e);
  free(raw); free(voxels); free(mask);
  return st == FFSEG_CONVERGED && dice >= 0.9 ? 0 : 1;
}
