// libFuzzer target "nrrd": the tools' NRRD reader on arbitrary bytes (a .nrrd with attached raw or gzip data;
// a header naming a detached data file is refused in memory), with the checks of fuzz_image.h on what it returns.
#include <cstdint>
#include <string>

#include "fuzz_image.h"
#include "nrrd.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ffseg_tools::NiftiLimits lim = ffseg_fuzz::reader_limits();
  ffseg_tools::NiftiImage img;
  std::string err;
  const bool ok = ffseg_tools::nrrd_read_memory(data, size, &img, &err, lim);
  return ffseg_fuzz::check_read("fuzz_nrrd", ok, img, err, lim);
}
