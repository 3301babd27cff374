#include "back/back_result_codec.h"

#include <cstring>

#include "ipc/byte_io.h"
#include "ipc/submap_codec.h"

namespace rumi {
namespace {

constexpr uint32_t kMagic = 0x53524252;  // "RBRS"

void PutString(std::vector<uint8_t>* out, const std::string& s) {
  const uint64_t n = s.size();
  out->insert(out->end(), reinterpret_cast<const uint8_t*>(&n), reinterpret_cast<const uint8_t*>(&n) + 8);
  out->insert(out->end(), s.begin(), s.end());
}
template <typename T>
void Put(std::vector<uint8_t>* out, const T& v) {
  static_assert(std::is_trivially_copyable<T>::value, "POD only");
  const auto* p = reinterpret_cast<const uint8_t*>(&v);
  out->insert(out->end(), p, p + sizeof(T));
}
std::string GetString(BufferReader& r, const char* field) {
  const uint64_t n = r.GetCount(1, field);
  const uint8_t* p = r.Take(n);
  return std::string(reinterpret_cast<const char*>(p), n);
}

}  // namespace

std::vector<uint8_t> EncodeBackResult(const BackResult& r) {
  std::vector<uint8_t> out;
  Put(&out, kMagic);
  Put(&out, kBackResultFormatVersion);
  Put(&out, uint16_t{0});
  Put(&out, r.window_id);
  Put(&out, static_cast<int32_t>(r.status));
  Put(&out, static_cast<int32_t>(r.num_frames));
  Put(&out, static_cast<int32_t>(r.num_registered));
  Put(&out, static_cast<int32_t>(r.matched_pairs));
  const uint8_t flags = (r.retried ? 1 : 0) | (r.retry_kept ? 2 : 0) | (r.filled ? 4 : 0) | (r.fill_kept ? 8 : 0);
  Put(&out, flags);
  const BackStepTimes& t = r.times;
  for (double v : {t.undistort_write_s, t.feature_extraction_s, t.matching_s, t.mapping_s, t.read_convert_s, t.total_s,
                   t.feature_extraction_cpu_s, t.matching_cpu_s, t.mapping_cpu_s})
    Put(&out, v);
  PutString(&out, r.message);
  Put(&out, uint64_t(r.warnings.size()));
  for (const std::string& w : r.warnings) PutString(&out, w);
  Put(&out, uint64_t(r.submaps.size()));
  for (size_t i = 0; i < r.submaps.size(); ++i) {
    const BackSubmapStats st = i < r.stats.size() ? r.stats[i] : BackSubmapStats{};
    Put(&out, int32_t(st.registered_images));
    Put(&out, int32_t(st.num_points));
    Put(&out, int32_t(st.num_observations));
    Put(&out, st.mean_reprojection_error_px);
    Put(&out, st.mean_track_length);
    const std::vector<uint8_t> s = EncodeSubmap(r.submaps[i]);
    Put(&out, uint64_t(s.size()));
    out.insert(out.end(), s.begin(), s.end());
  }
  Put(&out, Checksum64(out.data(), out.size()));
  return out;
}

bool DecodeBackResult(const uint8_t* data, size_t size, BackResult* r, std::string* error) {
  try {
    if (size < 16) throw CodecError("back result: truncated (" + std::to_string(size) + " bytes)");
    uint64_t sum;
    std::memcpy(&sum, data + size - 8, 8);
    BufferReader in(data, size - 8, "back result");
    if (in.Get<uint32_t>() != kMagic) in.Fail("not a back result (bad magic)");
    const uint16_t version = in.Get<uint16_t>();
    if (version != kBackResultFormatVersion)
      in.Fail("format version " + std::to_string(version) + ", this build reads " +
              std::to_string(kBackResultFormatVersion));
    in.Get<uint16_t>();
    if (Checksum64(data, size - 8) != sum) in.Fail("checksum mismatch (corrupt)");
    BackResult o;
    o.window_id = in.Get<int64_t>();
    const int32_t status = in.Get<int32_t>();
    if (status < 0 || status > static_cast<int32_t>(BackStatus::kModelError)) in.Fail("unknown status");
    o.status = static_cast<BackStatus>(status);
    o.num_frames = in.Get<int32_t>();
    o.num_registered = in.Get<int32_t>();
    o.matched_pairs = in.Get<int32_t>();
    const uint8_t flags = in.Get<uint8_t>();
    o.retried = flags & 1, o.retry_kept = flags & 2, o.filled = flags & 4, o.fill_kept = flags & 8;
    BackStepTimes& t = o.times;
    for (double* v : {&t.undistort_write_s, &t.feature_extraction_s, &t.matching_s, &t.mapping_s, &t.read_convert_s,
                      &t.total_s, &t.feature_extraction_cpu_s, &t.matching_cpu_s, &t.mapping_cpu_s})
      *v = in.Get<double>();
    o.message = GetString(in, "message");
    const uint64_t nw = in.GetCount(8, "warnings");
    for (uint64_t i = 0; i < nw; ++i) o.warnings.push_back(GetString(in, "warning"));
    const uint64_t ns = in.GetCount(40, "submaps");
    for (uint64_t i = 0; i < ns; ++i) {
      BackSubmapStats st;
      st.registered_images = in.Get<int32_t>();
      st.num_points = in.Get<int32_t>();
      st.num_observations = in.Get<int32_t>();
      st.mean_reprojection_error_px = in.Get<double>();
      st.mean_track_length = in.Get<double>();
      const uint64_t n = in.GetCount(1, "submap bytes");
      const uint8_t* p = in.Take(n);
      Submap s;
      std::string why;
      if (!DecodeSubmap(p, n, &s, &why)) in.Fail("submap " + std::to_string(i) + ": " + why);
      o.submaps.push_back(std::move(s));
      o.stats.push_back(st);
    }
    if (in.remaining() != 0) in.Fail(std::to_string(in.remaining()) + " trailing bytes");
    *r = std::move(o);
    return true;
  } catch (const CodecError& e) {
    if (error) *error = e.what();
    return false;
  }
}

}  // namespace rumi
