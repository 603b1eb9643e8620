/*
 * ffseg.h - the public C ABI of ffseg, a fixed-memory engine that segments
 * organs in 3D medical volumes by deforming a quadrilateral sphere mesh
 * without ever letting it flip or self-intersect (Ding Feng, "3D Segmentation
 * of Soft Tissues by Flipping-free Mesh Deformation", chapters 4-6).
 *
 * Rules this header keeps:
 *  - plain C: <stdint.h>/<stddef.h> types only, no bool, no enums in structs or
 *    signatures, no unions, bit-fields, variadics or inline functions;
 *  - every struct crossing the boundary starts with uint32_t struct_size; fields
 *    are only ever appended; the library reads min(struct_size, its own size),
 *    and *_init_default() fills one completely; no struct has implicit padding
 *    on 64-bit targets (reserved fields fill it), so an appended field always
 *    changes sizeof;
 *  - every call returns ffseg_status: 0 success, > 0 a non-error outcome,
 *    < 0 an error; error numbers never change once released;
 *  - nothing is ever allocated: the caller asks for the workspace size, hands
 *    over one 64-byte aligned buffer and owns it; no exception, abort or print
 *    crosses the boundary;
 *  - threading: one engine is used by one thread at a time; distinct engines
 *    may run in parallel on distinct workspaces;
 *  - geometry is in millimetres in the caller's world frame, the frame of the
 *    volume's 4x4 index-to-world affine (voxel centres). LPS or RAS does not
 *    matter: outputs come back in the same frame;
 *  - out-parameters on failure: each call below says what it writes when it
 *    fails; anything it does not name is left as the caller had it.
 *
 * Typical use:
 *     ffseg_config cfg;  ffseg_config_init_default(&cfg);  cfg.max_objects = 1;
 *     size_t bytes;      ffseg_workspace_size(&cfg, &bytes);
 *     void* ws = aligned_alloc(64, bytes);      (any 64-byte aligned memory)
 *     ffseg_engine* e;   ffseg_create(&cfg, ws, bytes, &e);
 *     ffseg_set_volume(e, &volume);
 *     ffseg_init_sphere(e, 0, centre_mm, radius_mm);
 *     while ((st = ffseg_step(e, NULL)) == FFSEG_OK) {}
 *         (st: FFSEG_CONVERGED, or FFSEG_DEGENERATE when some object's
 *         result is no segmentation, or an error)
 *     ffseg_extract_mesh(e, 0, xyz, nv_cap, tris, nt_cap, &nv, &nt);
 *     ffseg_destroy(e);  free(ws);
 */
#ifndef FFSEG_H
#define FFSEG_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#  if defined(FFSEG_BUILDING)
#    define FFSEG_API __declspec(dllexport)
#  else
#    define FFSEG_API
#  endif
#elif defined(__GNUC__)
#  define FFSEG_API __attribute__((visibility("default")))
#else
#  define FFSEG_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Version ------------------------------------------------------------ */
#define FFSEG_VERSION_MAJOR 0
#define FFSEG_VERSION_MINOR 8
#define FFSEG_VERSION_PATCH 0
#define FFSEG_VERSION_NUMBER \
  (FFSEG_VERSION_MAJOR * 10000 + FFSEG_VERSION_MINOR * 100 + FFSEG_VERSION_PATCH)

/* The library's version, MAJOR*10000 + MINOR*100 + PATCH. Compare with
 * FFSEG_VERSION_NUMBER to detect a header/library mismatch. Thread-safe. */
FFSEG_API uint32_t ffseg_version_number(void);

/* The engine: an opaque handle living inside the caller's workspace. */
typedef struct ffseg_engine ffseg_engine;

/* ---- Status codes ------------------------------------------------------- */
typedef int32_t ffseg_status;

#define FFSEG_OK 0
/* ffseg_step: every object has converged (mean displacement below tolerance). */
#define FFSEG_CONVERGED 1
/* Since 0.4.0. ffseg_step: every object has come to rest as for
 * FFSEG_CONVERGED, but the result of at least one is no segmentation, or
 * (since 0.5.0) only part of one: it stalled short of its boundary
 * (ffseg_step_info.object_flags says which and why: FFSEG_OBJECT_*). Not a
 * success, not an error: the meshes and masks can still be read. */
#define FFSEG_DEGENERATE 2

/* An argument is out of its documented range (the message names it). */
#define FFSEG_ERR_INVALID_ARGUMENT (-1)
/* A required pointer argument is NULL. */
#define FFSEG_ERR_NULL_POINTER (-2)
/* The workspace is smaller than ffseg_workspace_size() says (message: needed size). */
#define FFSEG_ERR_WORKSPACE_TOO_SMALL (-3)
/* The workspace is not 64-byte aligned. */
#define FFSEG_ERR_WORKSPACE_MISALIGNED (-4)
/* The volume descriptor is malformed (message: which field and why). */
#define FFSEG_ERR_INVALID_VOLUME (-5)
/* An object index is not below config.max_objects. */
#define FFSEG_ERR_OBJECT_OUT_OF_RANGE (-6)
/* An output buffer is too small; the needed counts are reported. */
#define FFSEG_ERR_BUFFER_TOO_SMALL (-7)
/* A call made in the wrong order (e.g. init_sphere before set_volume). */
#define FFSEG_ERR_MISUSE (-8)
/* A numeric failure (matrix not positive definite, non-finite values);
 * the mesh is left as it was before the call. */
#define FFSEG_ERR_NUMERIC (-9)
/* A cropped region needs more voxels than config.max_roi_voxels (several objects: than their
 * shared room has beside the other crops), or a bounding region more than
 * config.max_region_voxels even on its coarsest cells (message: how many). */
#define FFSEG_ERR_ROI_TOO_LARGE (-10)
/* The sphere does not meet the volume's grid. */
#define FFSEG_ERR_SPHERE_OUTSIDE (-11)
/* A struct's struct_size is smaller than the oldest layout the library knows. */
#define FFSEG_ERR_STRUCT_SIZE (-12)
/* The configuration asks for more memory than size_t can express. */
#define FFSEG_ERR_CONFIG_TOO_LARGE (-13)
/* The requested feature is not available in this build. */
#define FFSEG_ERR_NOT_IMPLEMENTED (-14)

/* Static text for a status code ("unknown status" for unknown codes). Thread-safe. */
FFSEG_API const char* ffseg_status_string(ffseg_status s);

/* The engine's last detailed message (stored in its workspace, valid until the
 * next call on that engine). With e == NULL: the last message of a call made
 * without an engine (ffseg_workspace_size, a failed ffseg_create) on the
 * calling thread. Never NULL; "" when there is nothing to say. */
FFSEG_API const char* ffseg_last_error(const ffseg_engine* e);

/* ---- Sizing and creation ------------------------------------------------ */

typedef struct ffseg_config {
  uint32_t struct_size;     /* sizeof(ffseg_config) */
  uint32_t max_objects;     /* objects segmented at once; 1..64 (default 1) */
  uint32_t mesh_resolution; /* n: each mesh has 6 n^2 vertices; 2..1024 (default 33) */
  uint32_t reserved0;       /* must be 0 */
  int64_t max_roi_voxels;   /* cropped region one object may use for smoothing (and, with
                               max_region_voxels 0, for its bounding region), in voxels;
                               0..2^40 (default 2^22). Several objects with grey-level
                               targets share one room of max_objects x max_roi_voxels for
                               their smoothed crops: a large organ may use more while
                               small ones use less, and a crop fails only when it does
                               not fit beside the others' */
  /* Since 0.2.0 (a shorter struct, struct_size 24, reads as the default): */
  uint32_t target_mode;     /* the target modes the engine will be asked for:
                               FFSEG_TARGET_INTENSITY (default) reserves the grey-level
                               buffers (smoothed crop, intensity model; both modes allowed);
                               FFSEG_TARGET_BINARY reserves none, much smaller workspace,
                               and ffseg_set_params refuses target_mode = intensity */
  uint32_t reserved1;       /* must be 0 */
  /* Since 0.6.0 (a shorter struct, struct_size 32, reads as the default): */
  int64_t max_region_voxels; /* several objects: the voxels one bounding region is marched
                               on (the shared fast marching, 22 bytes each, and each object's
                               arrival times, 4 bytes each); 0..2^40; 0 (default) = max_roi_voxels.
                               A region's box (mesh box grown by region_width_mm) with more
                               voxels is marched on cells of several voxels, the finest that
                               fit (its border then placed to within a cell); cells coarser
                               than half the region width are refused with
                               FFSEG_ERR_ROI_TOO_LARGE. So regions need not take memory in
                               proportion to the scan (thesis 7.2). */
} ffseg_config;

/* Fills *c with the defaults above and struct_size = sizeof(ffseg_config). */
FFSEG_API void ffseg_config_init_default(ffseg_config* c);

/* Exact workspace size in bytes for config *c: ffseg_create succeeds with this
 * many bytes and fails with one byte fewer. Errors: NULL_POINTER,
 * STRUCT_SIZE, INVALID_ARGUMENT (field named in ffseg_last_error(NULL)),
 * CONFIG_TOO_LARGE. On failure *bytes is set to 0 (when bytes is not NULL). */
FFSEG_API ffseg_status ffseg_workspace_size(const ffseg_config* c, size_t* bytes);

/* Creates an engine inside workspace[0, bytes). The workspace must be 64-byte
 * aligned and stay valid and untouched by the caller until ffseg_destroy; the
 * engine never allocates. On failure *out is set to NULL and
 * ffseg_last_error(NULL) explains (for WORKSPACE_TOO_SMALL it names the size). */
FFSEG_API ffseg_status ffseg_create(const ffseg_config* c, void* workspace, size_t bytes,
                                    ffseg_engine** out);

/* Ends the engine's use of its workspace. NULL is fine. Frees nothing: the
 * caller owns the workspace and may reuse or free it afterwards. */
FFSEG_API void ffseg_destroy(ffseg_engine* e);

/* ---- Algorithm parameters ------------------------------------------------ */
/* How ffseg_step finds targets for the vertices. */
#define FFSEG_TARGET_BINARY 0    /* non-zero voxels are the object (thesis ch. 4) */
#define FFSEG_TARGET_INTENSITY 1 /* grey levels, intensity model (thesis ch. 5) */

typedef struct ffseg_params {
  uint32_t struct_size;         /* sizeof(ffseg_params) */
  uint32_t target_mode;         /* FFSEG_TARGET_*; default FFSEG_TARGET_BINARY */
  double lambda_laplacian;      /* lambda_L, Laplacian preservation; (0, 1e6]; default 1 */
  double lambda_position;       /* lambda_p, positional constraints; [1e-6, 1e6]; default 1 (every
                                   vertex keeps an anchor of 1e-3 lambda_p that makes the system
                                   positive definite; far below 1e-6 it is numerically singular, and
                                   at the smallest doubles the anchor rounds to 0) */
  double lambda_uniform;        /* lambda_u, uniform edge length on contours, as a tension (edges longer
                                   than their loop's mean are drawn in); [0, 1e6]; default 0.25 */
  double step_size;             /* alpha: p_i = u_i + alpha (v_i - u_i); (0, 1]; default 0.5 */
  double flip_tau;              /* tau of eq. 4.2.1, edge flips when cos <= tau; [0, 1); default 0.2 */
  double search_range_mm;       /* correspondence search along the normal, mm; [0, 1e4]; 0 = automatic:
                                   80 mm for binary targets, 20 mm for grey levels; default 0 */
  double search_step_mm;        /* sample spacing along the normal, mm; 0 = half the smallest
                                   voxel spacing; [0, 100]; default 0 */
  double convergence_mm;        /* converged when every object's mean displacement is below (binary
                                   targets: first the mean motion along the vertex normals and the mean
                                   advance toward their targets of the vertices whose target lies beyond
                                   a voxel; then, while polishing, the mean displacement with at most 1%
                                   of the vertices moving more than 0.75x it; grey levels growing freely
                                   where their boundary is in view, see grey_respacing: the first of these
                                   at a tenth of it); [0, 100];
                                   default 0.05 */
  uint32_t diffusion_iterations; /* rounds of displacement averaging (eq. 4.2.2); 0..100; 0 = automatic:
                                    20 (n / 33)^2 for mesh resolution n (1 at least); with binary targets,
                                    once an object has come to rest it polishes with a twentieth of the
                                    rounds until it rests again; an odd count is rounded up (an odd number
                                    of rounds feeds a sawtooth); default 0 */
  uint32_t consecutive_background; /* N of thesis 5.3; 1..64; default 3 */
  /* Grey-level targets (FFSEG_TARGET_INTENSITY, thesis chapter 5): */
  uint32_t smoothing_iterations; /* Perona-Malik steps on the cropped region (eq. 5.2.1); 0..100; default 5 */
  uint32_t bin_min_count;        /* N_m of adaptive binning (Algorithm 2), samples; 0 = max(8, 5% of the
                                    samples in the sphere); 0..2^31; default 0 */
  double smoothing_kappa;        /* conductance contrast K of eq. 5.2.2, intensity per mm; 0 = from the
                                    region's noise estimate; [0, 1e9]; default 0 */
  double intensity_gamma;        /* Gamma: a sample is object when g(x) >= Gamma, g the intensity model's
                                    likelihood divided by its peak, and no competing class of the region more
                                    probable; (0, 1); default 0.2 */
  double sigma_floor_fraction;   /* lower bound on each Gaussian's standard deviation as a fraction of the
                                    1st-99th percentile range of the box of the search range around the
                                    sphere's centre (a small sphere in clean data under-estimates the
                                    spread); [0, 1]; default 0.04 */
  double bin_radius;             /* R of Algorithm 2, intensity units; 0 = 2 x the sigma floor; [0, 1e9]; default 0 */
  double bin_separation;         /* S of Algorithm 2, intensity units; 0 = 4 x the sigma floor; [0, 1e9]; default 0 */
  uint32_t partial_volume_steps; /* grey-level targets: once an object comes to rest, at most this many more
                                    steps with each boundary moved from where the intensity model gives up to
                                    the half-way level between the object's class and the competing class
                                    beyond it (partial-volume voxels that are mostly object), or until
                                    it rests again; 0 = off; 0..1000; default 4 */
  uint32_t reserved1;            /* must be 0; fills what would be tail padding after
                                    partial_volume_steps, so that a field appended later grows
                                    sizeof and struct_size tells the two layouts apart */
  /* Several objects (thesis chapter 6), since 0.3.0 (a shorter struct reads these as their
     defaults). They matter only while two or more objects are placed in one engine: */
  double region_width_mm;        /* w_i of eq. 6.2.6-6.2.11, mm: each object's bounding region lies in its
                                    mesh's bounding box grown by this much, and no front runs further
                                    than this from the mesh; 0 = automatic, 10 mm; [0, 1000]; default 0 */
  double border_weight;          /* positional weight of a border vertex (one whose search met another
                                    object's region, thesis 6.3), times lambda_p, so that the Laplacian
                                    solve does not push it past the border; (0, 1e9]; default 1000 */
  uint32_t region_interval;      /* steps between recomputations of the bounding regions (a region is
                                    also recomputed at once when its mesh comes within half of
                                    region_width_mm of its box); 1..1000; default 4 */
  /* Since 0.7.0 (0.3-0.6: reserved2, which had to be 0, the default): */
  uint32_t grey_respacing;       /* grey-level targets re-space their contour loops, as binary targets
                                    do, until they first come to rest (then the surface's motion and its
                                    fronts' advance decide the rest, as for binary targets): a mesh grows
                                    along a tube or a horn from a sphere at one end. It also carries a
                                    mesh through any gap that the intensity model leaves open between the
                                    organ and a neighbour of its grey level (abdominal CT: the aorta and
                                    gallbladder leak; Colin27's nuclei into their neighbours), so by
                                    default (0, since 0.8.0) an object grows so only where its boundary is
                                    in view of the box around its sphere: its grey level holds less than a
                                    quarter of the box, and the box's other classes less than 5% of the
                                    values it accepts (a vessel, a duct, a ventricle of its own contrast;
                                    not a soft-tissue organ in CT, not a nucleus among grey and white
                                    matter). 1: always; 2: never (0.7.0's default). Without it a grey-level
                                    mesh re-spaces only to leave a stall. A mesh growing so where its
                                    boundary is in view rests only when its surface and fronts move less
                                    than a tenth of convergence_mm: the diffusion averages the few
                                    vertices at a tube's tip with their resting neighbours, so the tip
                                    advances slowly (elsewhere, at 1 its rest is convergence_mm's).
                                    0..2; default 0 */
} ffseg_params;

/* Fills *p with the defaults above and struct_size = sizeof(ffseg_params). */
FFSEG_API void ffseg_params_init_default(ffseg_params* p);

/* Validates every field; on an error nothing changes, the previous parameters
 * stay, and the message names the field. Errors: NULL_POINTER, STRUCT_SIZE,
 * INVALID_ARGUMENT (reserved1 not 0 included). Writes nothing the caller owns. */
FFSEG_API ffseg_status ffseg_set_params(ffseg_engine* e, const ffseg_params* p);

/* ---- The volume ------------------------------------------------------------ */
#define FFSEG_U8 1
#define FFSEG_I16 2
#define FFSEG_U16 3
#define FFSEG_I32 4
#define FFSEG_F32 5
#define FFSEG_F64 6

typedef struct ffseg_volume {
  uint32_t struct_size;   /* sizeof(ffseg_volume) */
  uint32_t voxel_type;    /* FFSEG_U8 ... FFSEG_F64, native byte order */
  const void* data;       /* start of the readable buffer; never written */
  uint64_t data_bytes;    /* its length in bytes */
  int64_t offset;         /* bytes from data to voxel (0,0,0) */
  int64_t dims[3];        /* voxels along i, j, k; each >= 2 (a single slice is refused) */
  int64_t strides[3];     /* bytes between neighbours along i, j, k; may be negative
                             or padded; voxels must not overlap */
  double index_to_world[16]; /* row-major 4x4: voxel centre (i,j,k,1) -> mm; last row 0 0 0 1 */
  double rescale_slope;     /* value = slope * stored + intercept; finite, non-zero */
  double rescale_intercept; /* finite */
} ffseg_volume;

/* Voxel (i,j,k) is read at data + offset + i*strides[0] + j*strides[1] +
 * k*strides[2]. Everything is checked: dims < 1, a single slice (a dims of 1),
 * dimension products that
 * overflow 64 bits, NULL data, any voxel byte outside [data, data + data_bytes),
 * overlapping voxels, an unknown type, a singular or non-finite affine or a
 * last row other than 0 0 0 1, a zero or non-finite slope, a non-finite
 * intercept: each is FFSEG_ERR_INVALID_VOLUME with a message. The buffer is
 * borrowed until the next set_volume or destroy and never written. Setting a
 * volume keeps the objects' meshes. On failure the engine keeps the volume it
 * had before (so that volume's buffer stays borrowed) and writes nothing the
 * caller owns. */
FFSEG_API ffseg_status ffseg_set_volume(ffseg_engine* e, const ffseg_volume* v);

/* Intensity (rescaled) at a point in world mm. mode: 0 nearest voxel,
 * 1 trilinear. Voxels beyond the grid read as 0. Errors: MISUSE (no volume),
 * NULL_POINTER, INVALID_ARGUMENT (mode, non-finite point). On failure *value
 * is left untouched. */
#define FFSEG_SAMPLE_NEAREST 0
#define FFSEG_SAMPLE_LINEAR 1
FFSEG_API ffseg_status ffseg_sample(const ffseg_engine* e, const double point_mm[3],
                                    uint32_t mode, double* value);

/* ---- Objects ---------------------------------------------------------------- */
/* Places object `object`'s cube-sphere mesh on a sphere (centre and radius in
 * world mm), replacing any previous mesh of that object. Errors: MISUSE (no
 * volume yet), OBJECT_OUT_OF_RANGE, INVALID_ARGUMENT (radius <= 0 or
 * non-finite values), SPHERE_OUTSIDE (the ball does not meet the grid). On
 * failure the object keeps the mesh it had (or stays unplaced).
 * After a step no vertex lies beyond the grid's box (voxel centres +- half a
 * voxel; a partial scan's organ ends on the box's face): a sphere that reaches
 * beyond it is put onto the box by the first step (as far as the step guard
 * lets it), and every step keeps the vertices there. */
FFSEG_API ffseg_status ffseg_init_sphere(ffseg_engine* e, uint32_t object,
                                         const double center_mm[3], double radius_mm);

/* Since 0.5.0. Places object `object`'s mesh from another cube-sphere mesh:
 * xyz holds n_vertices = 6 n_src^2 vertices (3 floats each, world mm) in the
 * order ffseg_extract_mesh writes them, from an engine of mesh resolution
 * n_src (2..1024). Each vertex of this engine's mesh takes the source
 * mesh's position at the same point of the cube-sphere parametrisation
 * (bilinear over the source cells around it; n_src equal to this engine's
 * resolution copies). The grey-level model is learned, as ffseg_init_sphere
 * does, from the sphere (center_mm, radius_mm): give the sphere the source
 * mesh grew from. Coarse to fine: segment at a small resolution, extract,
 * init_mesh into an engine at the resolution wanted and step on; the fine
 * mesh starts where the coarse one stopped instead of at the sphere. Errors:
 * those of ffseg_init_sphere, NULL_POINTER, INVALID_ARGUMENT (n_vertices not
 * 6 n^2 for an n in 2..1024, a non-finite vertex, a resampled mesh that
 * crosses itself or another object). On failure the object keeps the mesh
 * it had. */
FFSEG_API ffseg_status ffseg_init_mesh(ffseg_engine* e, uint32_t object, const double center_mm[3],
                                       double radius_mm, const float* xyz, size_t n_vertices);

/* Per-stage timings reported by ffseg_step, in microseconds. */
#define FFSEG_STAGE_SEARCH 0
#define FFSEG_STAGE_FLIPS 1
#define FFSEG_STAGE_DIFFUSION 2
#define FFSEG_STAGE_INTERSECTION 3
#define FFSEG_STAGE_ASSEMBLY 4
#define FFSEG_STAGE_FACTOR 5
#define FFSEG_STAGE_SOLVE 6
#define FFSEG_STAGE_FEATURES 7 /* grey levels: smoothing the crop, fitting the model */
#define FFSEG_STAGE_GUARD 8    /* the line search that keeps the update flip- and fold-free */
#define FFSEG_STAGE_REGIONS 9  /* several objects: the bounding regions (fast marching, thesis 6.2) */
#define FFSEG_STAGE_COUNT 10
/* Per-object figures are reported for the first FFSEG_REPORT_OBJECTS objects. */
#define FFSEG_REPORT_OBJECTS 16

/* Since 0.4.0: the bits of ffseg_step_info.object_flags. */
/* No vertex of the object found a boundary in any step since it was placed
 * (or since the last ffseg_set_volume / ffseg_set_params): its mesh only
 * stood still, e.g. a sphere in uniform background or around the whole scan. */
#define FFSEG_OBJECT_NO_BOUNDARY 1u
/* More than 80% of the grid's voxels have their centres inside the object's
 * mesh (the voxels ffseg_rasterize sets): it swallowed the background (a
 * leak, or a sphere placed around everything). An organ that truly fills
 * that much of its scan is flagged too: crop the volume with a margin. */
#define FFSEG_OBJECT_FILLS_GRID 2u
/* Since 0.5.0. The object came to rest without reaching its boundary: at its
 * first rest more than a tenth of its vertices, on balance, still had targets
 * more than a voxel (the largest spacing) away on one side (outward: it
 * stopped short; inward: it overshot), so the guard, the fold prevention or
 * a creeping mean held it, not the image. Its mesh is a partial result;
 * ffseg_step_info.far_outward / far_inward give the counts. */
#define FFSEG_OBJECT_STALLED 4u

typedef struct ffseg_step_info {
  uint32_t struct_size;   /* sizeof(ffseg_step_info) */
  uint32_t step_index;    /* steps taken so far, this one included */
  uint32_t active_objects;
  uint32_t reserved0;
  double mean_displacement_mm[FFSEG_REPORT_OBJECTS];
  uint32_t vertices_with_target[FFSEG_REPORT_OBJECTS];
  uint32_t flips_avoided[FFSEG_REPORT_OBJECTS];
  uint32_t intersections_avoided[FFSEG_REPORT_OBJECTS];
  uint32_t border_vertices[FFSEG_REPORT_OBJECTS];
  uint64_t stage_us[FFSEG_STAGE_COUNT];
  /* Since 0.4.0; a caller's struct of an older header, which ends before
   * these, gets the fields above only. */
  uint32_t object_flags[FFSEG_REPORT_OBJECTS]; /* FFSEG_OBJECT_* of each reported object as of its last
                                                  step (an object at rest keeps them); 0: looks like a
                                                  segmentation */
  uint32_t flags_all;     /* every placed object's flags or-ed, those beyond FFSEG_REPORT_OBJECTS too */
  uint32_t reserved1;     /* written 0 */
  /* Since 0.5.0; a caller's struct of 0.4.0, which ends before these, gets
   * the fields above only. Per object, this step: */
  uint32_t guard_held[FFSEG_REPORT_OBJECTS];  /* vertices the step guard held to less than half of
                                                 their solved update (a fold, a crossing, a contact) */
  uint32_t far_outward[FFSEG_REPORT_OBJECTS]; /* vertices whose target lay more than a voxel outward */
  uint32_t far_inward[FFSEG_REPORT_OBJECTS];  /* ... and inward (see FFSEG_OBJECT_STALLED) */
  /* Since 0.8.0; a caller's struct of 0.5-0.7, which ends before this, gets
   * the fields above only. */
  uint32_t respaced[FFSEG_REPORT_OBJECTS];    /* 1: the object's mesh re-spaced its contour loops this
                                                 step (binary targets until their first rest; grey
                                                 levels by params.grey_respacing, or to leave a stall) */
} ffseg_step_info;

/* One deformation step of every placed object (thesis Algorithm 1). Returns
 * FFSEG_OK while some object moves; once every object's mean displacement is
 * below params.convergence_mm, FFSEG_CONVERGED, or FFSEG_DEGENERATE instead
 * when some object's flags (FFSEG_OBJECT_*) are not 0. A loop
 * `while (ffseg_step(e, NULL) == FFSEG_OK)` ends on either; only
 * FFSEG_CONVERGED is a success. An object that has converged stays where it is on
 * later steps (its report reads 0 mm) until ffseg_init_sphere places it again
 * or ffseg_set_params / ffseg_set_volume change what it deforms towards, so
 * stepping past convergence is harmless. info may be NULL; otherwise info->struct_size must be
 * set (sizeof(ffseg_step_info) of this header or of an older one). Errors:
 * MISUSE (no volume or no object), NUMERIC (mesh unchanged),
 * ROI_TOO_LARGE, NOT_IMPLEMENTED (a target mode this build lacks),
 * STRUCT_SIZE (info->struct_size smaller than 0.3.0's, which ends at stage_us), and with
 * grey-level targets SPHERE_OUTSIDE (the sphere holds no voxel centre of its
 * cropped region, e.g. a sphere smaller than a voxel between voxel centres, or
 * the mesh has left the grid; the mesh is unchanged). *info is written only
 * when the call returns FFSEG_OK, FFSEG_CONVERGED or FFSEG_DEGENERATE; on an
 * error it is left untouched. */
FFSEG_API ffseg_status ffseg_step(ffseg_engine* e, ffseg_step_info* info);

/* Copies object `object`'s mesh out: xyz gets 3 floats (mm) per vertex, tris
 * 3 vertex indices per triangle, counter-clockwise seen from outside (each quad
 * split in two; a closed, consistently oriented 2-manifold). With xyz and tris
 * both NULL only the counts are written. A buffer smaller than the counts:
 * BUFFER_TOO_SMALL, with the counts written. Capacities are in vertices and
 * triangles. Either buffer alone may be NULL (only the other is filled), and
 * so may n_vertices and n_tris. Errors also: OBJECT_OUT_OF_RANGE, MISUSE
 * (object not placed). On BUFFER_TOO_SMALL only the counts are written, xyz
 * and tris are untouched; on any other error nothing is written. */
FFSEG_API ffseg_status ffseg_extract_mesh(const ffseg_engine* e, uint32_t object, float* xyz,
                                          size_t xyz_capacity, uint32_t* tris,
                                          size_t tri_capacity, size_t* n_vertices,
                                          size_t* n_tris);

/* Writes 1 into mask for every voxel of the volume grid whose centre lies
 * inside object `object`'s closed mesh and 0 for every other voxel. Voxel
 * (i,j,k) is mask[i*strides[0] + j*strides[1] + k*strides[2]] (bytes, may be
 * negative); strides == NULL means contiguous (1, dims[0], dims[0]*dims[1]).
 * The caller guarantees the buffer covers the grid. Errors: MISUSE,
 * OBJECT_OUT_OF_RANGE, NULL_POINTER. On failure mask is untouched. */
FFSEG_API ffseg_status ffseg_rasterize(const ffseg_engine* e, uint32_t object, uint8_t* mask,
                                       const int64_t strides[3]);

/* Since 0.3.0. Writes object `object`'s bounding region (thesis 6.2, fig.
 * 6.4) into mask: 1 for every voxel of the volume grid that the object owns,
 * 0 for every other voxel. While two or more objects are placed, each
 * ffseg_step first brings every object's region up to date: fast marching
 * from the voxels inside its mesh, within its mesh's bounding box grown by
 * params.region_width_mm, at a speed given by the object's intensity model
 * (binary targets: 1 on non-zero voxels, 0 elsewhere); a voxel belongs to the
 * object whose front reaches it first (ties: the lower object index), and to
 * none when no front reaches it. So the regions of distinct objects never
 * share a voxel, and each object's mesh deforms within its own region (a
 * vertex whose search meets another object's region is a border vertex,
 * counted in ffseg_step_info.border_vertices). The mask shows the regions
 * that the last step used: a region is recomputed every
 * params.region_interval steps and whenever its mesh nears its box's faces,
 * not after every step. Layout as ffseg_rasterize: voxel (i,j,k) is
 * mask[i*strides[0] + j*strides[1] + k*strides[2]], strides == NULL means
 * contiguous, and the caller guarantees the buffer covers the grid.
 * Errors: NULL_POINTER (mask), OBJECT_OUT_OF_RANGE, MISUSE: no volume, object
 * not placed, or the object has no region yet: a one-object engine
 * (max_objects = 1) has none, and neither has an engine before its first
 * ffseg_step with two or more objects placed, nor an object since
 * ffseg_init_sphere placed it again or ffseg_set_volume changed the volume
 * (until the next step). On failure mask is untouched. */
FFSEG_API ffseg_status ffseg_region_mask(const ffseg_engine* e, uint32_t object, uint8_t* mask,
                                         const int64_t strides[3]);

#ifdef __cplusplus
}
#endif

#endif /* FFSEG_H */
