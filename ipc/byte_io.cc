#include "ipc/byte_io.h"

namespace rumi {

uint64_t Checksum64(const uint8_t* data, size_t n, uint64_t seed) {
  // Four independent lanes keep the multiply latency off the critical path.
  constexpr uint64_t kMul = 0xff51afd7ed558ccdULL;
  uint64_t h[4] = {seed, seed ^ 0xc4ceb9fe1a85ec53ULL, seed + n, ~seed};
  size_t i = 0;
  for (; i + 32 <= n; i += 32) {
    for (int k = 0; k < 4; ++k) {
      uint64_t w;
      std::memcpy(&w, data + i + 8 * k, 8);
      h[k] = (h[k] ^ w) * kMul;
      h[k] ^= h[k] >> 29;
    }
  }
  uint64_t tail = 0;
  for (; i < n; ++i) tail = tail * 257 + data[i] + 1;
  uint64_t x = h[0] ^ (h[1] * 3) ^ (h[2] * 5) ^ (h[3] * 7) ^ (tail * kMul) ^ n;
  x ^= x >> 33;
  x *= kMul;
  x ^= x >> 33;
  return x;
}

cv::Mat GetMat(BufferReader& r, bool in_place, const char* field) {
  const int32_t rows = r.Get<int32_t>();
  const int32_t cols = r.Get<int32_t>();
  const int32_t type = r.Get<int32_t>();
  r.Get<int32_t>();
  if (rows < 0 || cols < 0) r.Fail(std::string(field) + ": negative matrix size");
  const int depth = CV_MAT_DEPTH(type);
  const int channels = CV_MAT_CN(type);
  if (type < 0 || type != CV_MAKETYPE(depth, channels) || depth > CV_16F || channels > 4) {
    r.Fail(std::string(field) + ": bad matrix type " + std::to_string(type));
  }
  if (rows == 0 || cols == 0) {
    if (rows != 0 || cols != 0) r.Fail(std::string(field) + ": half-empty matrix");
    cv::Mat m;
    m.flags = (m.flags & ~CV_MAT_TYPE_MASK) | type;  // keep the type of an empty Mat
    return m;
  }
  const size_t elem = CV_ELEM_SIZE(type);
  const uint64_t bytes = static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols) * elem;
  if (bytes > r.remaining()) {
    r.Fail(std::string(field) + ": matrix of " + std::to_string(bytes) + " bytes is truncated");
  }
  const uint8_t* p = r.Take(bytes);
  cv::Mat view(rows, cols, type, const_cast<uint8_t*>(p));
  return in_place ? view : view.clone();
}

}  // namespace rumi
