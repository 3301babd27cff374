#pragma once
// Little helpers for the rumi binary formats (ipc/submap_codec, ipc/window_codec).
// Encoding runs twice over the same code: once with a SizeCounter to learn the
// exact size, once with a BufferWriter straight into the destination (a ring
// slot or a file buffer), so image bytes are copied exactly once.
// Everything is little-endian host order (x86-64 / aarch64 Linux only).
#include <opencv2/core.hpp>

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace rumi {

// Thrown by readers on truncated or malformed input; the codecs turn it into
// a false return with the message.
class CodecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class SizeCounter {
 public:
  template <typename T>
  void Put(const T&) {
    static_assert(std::is_trivially_copyable<T>::value, "POD only");
    size_ += sizeof(T);
  }
  void PutBytes(const void*, size_t n) { size_ += n; }
  void Align(size_t a) { size_ = (size_ + a - 1) / a * a; }
  size_t size() const { return size_; }
  // Placeholder support: counters have nothing to patch.
  size_t Reserve(size_t n) { size_t at = size_; size_ += n; return at; }
  template <typename T>
  void PatchAt(size_t, const T&) {}

 private:
  size_t size_ = 0;
};

class BufferWriter {
 public:
  BufferWriter(uint8_t* data, size_t capacity) : data_(data), cap_(capacity) {}
  template <typename T>
  void Put(const T& v) {
    static_assert(std::is_trivially_copyable<T>::value, "POD only");
    PutBytes(&v, sizeof(T));
  }
  void PutBytes(const void* p, size_t n) {
    if (n > cap_ - pos_) throw CodecError("encoder overflow (size pass disagrees)");
    if (n) std::memcpy(data_ + pos_, p, n);
    pos_ += n;
  }
  void Align(size_t a) {
    const size_t to = (pos_ + a - 1) / a * a;
    if (to > cap_) throw CodecError("encoder overflow (size pass disagrees)");
    std::memset(data_ + pos_, 0, to - pos_);
    pos_ = to;
  }
  size_t Reserve(size_t n) {
    const size_t at = pos_;
    if (n > cap_ - pos_) throw CodecError("encoder overflow (size pass disagrees)");
    std::memset(data_ + pos_, 0, n);
    pos_ += n;
    return at;
  }
  template <typename T>
  void PatchAt(size_t at, const T& v) { std::memcpy(data_ + at, &v, sizeof(T)); }
  size_t size() const { return pos_; }
  uint8_t* data() { return data_; }

 private:
  uint8_t* data_;
  size_t cap_;
  size_t pos_ = 0;
};

class BufferReader {
 public:
  BufferReader(const uint8_t* data, size_t size, std::string what)
      : data_(data), size_(size), what_(std::move(what)) {}
  template <typename T>
  T Get() {
    static_assert(std::is_trivially_copyable<T>::value, "POD only");
    T v;
    std::memcpy(&v, Take(sizeof(T)), sizeof(T));
    return v;
  }
  const uint8_t* Take(size_t n) {
    if (n > size_ - pos_) {
      throw CodecError(what_ + ": truncated (need " + std::to_string(n) + " bytes at offset " +
                       std::to_string(pos_) + ", have " + std::to_string(size_ - pos_) + ")");
    }
    const uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  void Align(size_t a) {
    const size_t to = (pos_ + a - 1) / a * a;
    if (to > size_) throw CodecError(what_ + ": truncated in padding");
    pos_ = to;
  }
  // A count read from the input is only believed when that many elements of at
  // least min_bytes each could still follow: a flipped bit can't make us
  // allocate gigabytes.
  uint64_t GetCount(size_t min_bytes, const char* field) {
    const uint64_t n = Get<uint64_t>();
    if (min_bytes > 0 && n > remaining() / min_bytes) {
      throw CodecError(what_ + ": " + field + " count " + std::to_string(n) +
                       " exceeds the remaining " + std::to_string(remaining()) + " bytes");
    }
    return n;
  }
  size_t remaining() const { return size_ - pos_; }
  size_t pos() const { return pos_; }
  const std::string& what() const { return what_; }
  [[noreturn]] void Fail(const std::string& why) const {
    throw CodecError(what_ + ": " + why + " (at offset " + std::to_string(pos_) + ")");
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
  std::string what_;
};

// 64-bit checksum over a byte range, word at a time (several GB/s); used for
// the metadata of windows and the whole body of submaps.
uint64_t Checksum64(const uint8_t* data, size_t n, uint64_t seed = 0x9e3779b97f4a7c15ULL);

// cv::Mat as (rows i32, cols i32, type i32, pad i32, bytes). Any continuous or
// strided Mat is written row by row; empty Mats keep their type.
template <typename W>
void PutMat(W& w, const cv::Mat& m) {
  w.template Put<int32_t>(m.rows);
  w.template Put<int32_t>(m.cols);
  w.template Put<int32_t>(m.type());
  w.template Put<int32_t>(0);
  if (m.empty()) return;
  const size_t row_bytes = static_cast<size_t>(m.cols) * m.elemSize();
  if (m.isContinuous()) {
    w.PutBytes(m.data, row_bytes * m.rows);
  } else {
    for (int r = 0; r < m.rows; ++r) w.PutBytes(m.ptr(r), row_bytes);
  }
}

// Reads a Mat written by PutMat. in_place: header onto the input bytes
// (valid while the input is), else a deep copy.
cv::Mat GetMat(BufferReader& r, bool in_place, const char* field);

}  // namespace rumi
