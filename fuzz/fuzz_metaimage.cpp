// libFuzzer target "metaimage": the tools' MetaImage reader on arbitrary bytes (a .mha with ElementDataFile =
// LOCAL, raw or zlib-compressed), with the checks of fuzz_image.h on what it returns.
#include <cstdint>
#include <string>

#include "fuzz_image.h"
#include "metaimage.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ffseg_tools::NiftiLimits lim = ffseg_fuzz::reader_limits();
  ffseg_tools::NiftiImage img;
  std::string err;
  const bool ok = ffseg_tools::metaimage_read_memory(data, size, &img, &err, lim);
  return ffseg_fuzz::check_read("fuzz_metaimage", ok, img, err, lim);
}
