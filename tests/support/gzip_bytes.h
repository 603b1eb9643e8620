// gzip-compresses a byte buffer in memory (tests build .nii.gz inputs with it).
#pragma once
#include <cstdint>
#include <vector>

namespace ffseg_test {

std::vector<uint8_t> gzip_bytes(const std::vector<uint8_t>& in, int level = 6);

}  // namespace ffseg_test
