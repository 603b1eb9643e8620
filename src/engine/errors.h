// The engine's outcomes; the C API maps them one to one onto ffseg_status.
#pragma once

namespace ffseg {

enum class Err : int {
  ok = 0,
  converged,
  degenerate,  // every object at rest, but some object's result is no segmentation (ObjectFlag)
  invalid_argument,
  null_pointer,
  workspace_too_small,
  workspace_misaligned,
  invalid_volume,
  object_out_of_range,
  buffer_too_small,
  misuse,
  numeric,
  roi_too_large,
  sphere_outside,
  config_too_large,
  not_implemented,
};

}  // namespace ffseg
