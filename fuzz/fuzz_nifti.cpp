// libFuzzer target "nifti": the tools' NIfTI-1 reader on arbitrary bytes
// (.nii and .nii.gz alike: the reader detects gzip from the magic bytes), with
// the checks of fuzz_image.h on what it returns.
#include <cstdint>
#include <string>

#include "fuzz_image.h"
#include "nifti.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ffseg_tools::NiftiLimits lim = ffseg_fuzz::reader_limits();
  ffseg_tools::NiftiImage img;
  std::string err;
  const bool ok = ffseg_tools::nifti_read_memory(data, size, &img, &err, lim);
  return ffseg_fuzz::check_read("fuzz_nifti", ok, img, err, lim);
}
