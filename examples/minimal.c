/* minimal.c - the whole round trip through the C API on a synthetic volume:
 * size a workspace, create an engine, hand it a volume, place a sphere, take
 * the mesh back as triangles and as a voxel mask. Plain C99. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ffseg.h"

#define CHECK(call)                                                                      \
  do {                                                                                   \
    ffseg_status st_ = (call);                                                           \
    if (st_ < 0) {                                                                       \
      fprintf(stderr, "%s failed: %s (%s)\n", #call, ffseg_status_string(st_),           \
              ffseg_last_error(engine));                                                 \
      return 1;                                                                          \
    }                                                                                    \
  } while (0)

int main(void) {
  enum { NX = 48, NY = 40, NZ = 24 };
  ffseg_engine* engine = NULL;
  ffseg_config cfg;
  ffseg_volume vol;
  size_t bytes = 0, nv = 0, nt = 0, inside = 0, i;
  void* raw;
  void* ws;
  float* xyz;
  uint32_t* tris;
  uint8_t* mask;
  int16_t* voxels = (int16_t*)calloc((size_t)NX * NY * NZ, sizeof(int16_t));
  const double center[3] = {24.0, 20.0, 24.0}; /* mm */
  const double radius = 10.0;

  if (voxels == NULL) return 1;
  ffseg_config_init_default(&cfg);
  cfg.max_objects = 1;
  cfg.mesh_resolution = 16;
  if (ffseg_workspace_size(&cfg, &bytes) != FFSEG_OK) {
    fprintf(stderr, "workspace_size: %s\n", ffseg_last_error(NULL));
    return 1;
  }
  /* Any 64-byte aligned memory will do: here malloc plus manual alignment (C99). */
  raw = malloc(bytes + 63);
  if (raw == NULL) return 1;
  ws = (void*)(((uintptr_t)raw + 63) & ~(uintptr_t)63);
  if (ffseg_create(&cfg, ws, bytes, &engine) != FFSEG_OK) {
    fprintf(stderr, "create: %s\n", ffseg_last_error(NULL));
    return 1;
  }

  memset(&vol, 0, sizeof vol);
  vol.struct_size = sizeof vol;
  vol.voxel_type = FFSEG_I16;
  vol.data = voxels;
  vol.data_bytes = (uint64_t)NX * NY * NZ * sizeof(int16_t);
  vol.dims[0] = NX; vol.dims[1] = NY; vol.dims[2] = NZ;
  vol.strides[0] = 2; vol.strides[1] = 2 * NX; vol.strides[2] = 2 * NX * NY;
  vol.index_to_world[0] = 1.0;  /* 1 x 1 x 2 mm voxels */
  vol.index_to_world[5] = 1.0;
  vol.index_to_world[10] = 2.0;
  vol.index_to_world[15] = 1.0;
  vol.rescale_slope = 1.0;
  CHECK(ffseg_set_volume(engine, &vol));
  CHECK(ffseg_init_sphere(engine, 0, center, radius));

  CHECK(ffseg_extract_mesh(engine, 0, NULL, 0, NULL, 0, &nv, &nt));
  xyz = (float*)malloc(nv * 3 * sizeof(float));
  tris = (uint32_t*)malloc(nt * 3 * sizeof(uint32_t));
  mask = (uint8_t*)malloc((size_t)NX * NY * NZ);
  if (!xyz || !tris || !mask) return 1;
  CHECK(ffseg_extract_mesh(engine, 0, xyz, nv, tris, nt, &nv, &nt));
  CHECK(ffseg_rasterize(engine, 0, mask, NULL));
  for (i = 0; i < (size_t)NX * NY * NZ; ++i) inside += mask[i];

  printf("ffseg %u: workspace %zu bytes, mesh %zu vertices %zu triangles, "
         "%zu voxels inside (%.0f mm^3, sphere %.0f mm^3)\n",
         ffseg_version_number(), bytes, nv, nt, inside, inside * 2.0,
         4.0 / 3.0 * 3.14159265358979 * radius * radius * radius);
  ffseg_destroy(engine);
  free(raw); free(xyz); free(tris); free(mask); free(voxels);
  return nv == 6u * 16u * 16u && nt == 12u * 16u * 16u - 4u && inside > 0 ? 0 : 1;
}
