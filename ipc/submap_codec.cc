#include "ipc/submap_codec.h"

#include <cmath>

#include "ipc/envelope.h"

namespace rumi {
namespace {

constexpr uint32_t kKind = FourCc("SMAP");
constexpr uint32_t kHead = FourCc("HEAD");
constexpr uint32_t kKeyframes = FourCc("KFRM");
constexpr uint32_t kPoints = FourCc("PNTS");
constexpr uint32_t kFrames = FourCc("FRMS");
// Optional (written only when the submap has odometry; readers without it
// skip the section): the pose source at the submap's frames.
constexpr uint32_t kOdometry = FourCc("ODOM");

template <typename W>
void PutSe3(W& w, const Se3& T) {
  const auto& q = T.rotation();
  w.template Put<double>(q.x());
  w.template Put<double>(q.y());
  w.template Put<double>(q.z());
  w.template Put<double>(q.w());
  for (int i = 0; i < 3; ++i) w.template Put<double>(T.translation()[i]);
}

Se3 GetSe3(BufferReader& r) {
  double v[7];
  for (double& x : v) x = r.Get<double>();
  const Eigen::Quaterniond q(v[3], v[0], v[1], v[2]);
  const double n = q.norm();
  if (!(std::abs(n - 1.0) < 1e-6)) r.Fail("pose rotation is not a unit quaternion");
  return Se3::FromUnitQuaternion(q, Eigen::Vector3d(v[4], v[5], v[6]));
}

template <typename W>
void EncodeBody(W& w, const Submap& s) {
  BeginEnvelope(w, kKind, kSubmapFormatVersion);

  size_t at = BeginSection(w, kHead);
  w.template Put<int64_t>(s.id);
  w.template Put<uint8_t>(static_cast<uint8_t>(s.source));
  w.Align(8);
  w.template Put<int32_t>(s.camera.width);
  w.template Put<int32_t>(s.camera.height);
  w.template Put<double>(s.camera.fx);
  w.template Put<double>(s.camera.fy);
  w.template Put<double>(s.camera.cx);
  w.template Put<double>(s.camera.cy);
  EndSection(w, at);

  at = BeginSection(w, kKeyframes);
  w.template Put<uint64_t>(s.keyframes.size());
  for (const Keyframe& k : s.keyframes) {
    w.template Put<int64_t>(k.id);
    w.template Put<int64_t>(k.timestamp);
    PutSe3(w, k.T_cw);
    w.template Put<uint64_t>(k.keypoints.size());
    for (const auto& p : k.keypoints) {
      w.template Put<float>(p.x());
      w.template Put<float>(p.y());
    }
    w.template Put<uint64_t>(k.octaves.size());
    w.PutBytes(k.octaves.data(), k.octaves.size());
    w.Align(8);
    PutMat(w, k.descriptors);
    w.Align(8);
    w.template Put<uint64_t>(k.point_ids.size());
    w.PutBytes(k.point_ids.data(), k.point_ids.size() * sizeof(int64_t));
  }
  EndSection(w, at);

  at = BeginSection(w, kPoints);
  w.template Put<uint64_t>(s.points.size());
  for (const MapPoint& p : s.points) {
    w.template Put<int64_t>(p.id);
    for (int i = 0; i < 3; ++i) w.template Put<double>(p.position[i]);
    PutMat(w, p.descriptor);
    w.Align(8);
    w.template Put<uint64_t>(p.observations.size());
    for (const auto& o : p.observations) {
      w.template Put<int64_t>(o.keyframe_id);
      w.template Put<int32_t>(o.keypoint_index);
      w.template Put<int32_t>(0);
    }
  }
  EndSection(w, at);

  at = BeginSection(w, kFrames);
  w.template Put<uint64_t>(s.frames.size());
  for (const FrameRecord& f : s.frames) {
    w.template Put<int64_t>(f.timestamp);
    w.template Put<int64_t>(f.submap_id);
    w.template Put<uint64_t>(static_cast<uint8_t>(f.state));
    PutSe3(w, f.T_wc);
  }
  EndSection(w, at);

  if (!s.odometry.empty()) {
    at = BeginSection(w, kOdometry);
    w.template Put<uint64_t>(s.odometry.size());
    for (const OdometryPose& o : s.odometry) {
      w.template Put<int64_t>(o.timestamp);
      PutSe3(w, o.T_wb);
    }
    EndSection(w, at);
  }
}

void CheckEnd(const BufferReader& r) {
  if (r.remaining() != 0) r.Fail("section has " + std::to_string(r.remaining()) + " unread bytes");
}

}  // namespace

size_t EncodedSubmapSize(const Submap& s) {
  return EnvelopeSize([&](auto& w) { EncodeBody(w, s); });
}

size_t EncodeSubmapInto(const Submap& s, uint8_t* out, size_t capacity) {
  return EncodeEnvelopeInto([&](auto& w) { EncodeBody(w, s); }, out, capacity);
}

std::vector<uint8_t> EncodeSubmap(const Submap& s) {
  return EncodeEnvelope([&](auto& w) { EncodeBody(w, s); });
}

bool DecodeSubmap(const uint8_t* data, size_t size, Submap* out, std::string* error) {
  const std::string what = "submap record";
  try {
    const auto sections = ParseEnvelope(data, size, kKind, kSubmapFormatVersion, what);
    Submap s;
    {
      const Section& sec = FindSection(sections, kHead, what);
      BufferReader r(sec.data, sec.size, what + " HEAD");
      s.id = r.Get<int64_t>();
      const uint8_t src = r.Get<uint8_t>();
      if (src > static_cast<uint8_t>(SubmapSource::kMerged)) r.Fail("unknown submap source " + std::to_string(src));
      s.source = static_cast<SubmapSource>(src);
      r.Align(8);
      s.camera.width = r.Get<int32_t>();
      s.camera.height = r.Get<int32_t>();
      s.camera.fx = r.Get<double>();
      s.camera.fy = r.Get<double>();
      s.camera.cx = r.Get<double>();
      s.camera.cy = r.Get<double>();
      CheckEnd(r);
    }
    {
      const Section& sec = FindSection(sections, kKeyframes, what);
      BufferReader r(sec.data, sec.size, what + " KFRM");
      const uint64_t n = r.GetCount(96, "keyframe");
      s.keyframes.resize(n);
      for (Keyframe& k : s.keyframes) {
        k.id = r.Get<int64_t>();
        k.timestamp = r.Get<int64_t>();
        k.T_cw = GetSe3(r);
        const uint64_t nk = r.GetCount(8, "keypoint");
        k.keypoints.resize(nk);
        for (auto& p : k.keypoints) {
          p.x() = r.Get<float>();
          p.y() = r.Get<float>();
        }
        const uint64_t no = r.GetCount(1, "octave");
        const uint8_t* o = r.Take(no);
        k.octaves.assign(o, o + no);
        r.Align(8);
        k.descriptors = GetMat(r, false, "keyframe descriptors");
        r.Align(8);
        const uint64_t np = r.GetCount(8, "point id");
        k.point_ids.resize(np);
        if (np) std::memcpy(k.point_ids.data(), r.Take(np * 8), np * 8);
      }
      CheckEnd(r);
    }
    {
      const Section& sec = FindSection(sections, kPoints, what);
      BufferReader r(sec.data, sec.size, what + " PNTS");
      const uint64_t n = r.GetCount(56, "map point");
      s.points.resize(n);
      for (MapPoint& p : s.points) {
        p.id = r.Get<int64_t>();
        for (int i = 0; i < 3; ++i) p.position[i] = r.Get<double>();
        p.descriptor = GetMat(r, false, "map point descriptor");
        r.Align(8);
        const uint64_t no = r.GetCount(16, "observation");
        p.observations.resize(no);
        for (auto& ob : p.observations) {
          ob.keyframe_id = r.Get<int64_t>();
          ob.keypoint_index = r.Get<int32_t>();
          r.Get<int32_t>();
        }
      }
      CheckEnd(r);
    }
    {
      const Section& sec = FindSection(sections, kFrames, what);
      BufferReader r(sec.data, sec.size, what + " FRMS");
      const uint64_t n = r.GetCount(80, "frame record");
      s.frames.resize(n);
      for (FrameRecord& f : s.frames) {
        f.timestamp = r.Get<int64_t>();
        f.submap_id = r.Get<int64_t>();
        const uint64_t st = r.Get<uint64_t>();
        if (st > static_cast<uint8_t>(TrackingState::kCoarse)) r.Fail("unknown tracking state " + std::to_string(st));
        f.state = static_cast<TrackingState>(st);
        f.T_wc = GetSe3(r);
      }
      CheckEnd(r);
    }
    if (const Section* sec = FindOptionalSection(sections, kOdometry)) {
      BufferReader r(sec->data, sec->size, what + " ODOM");
      const uint64_t n = r.GetCount(64, "odometry pose");
      s.odometry.resize(n);
      for (OdometryPose& o : s.odometry) {
        o.timestamp = r.Get<int64_t>();
        o.T_wb = GetSe3(r);
      }
      CheckEnd(r);
    }
    *out = std::move(s);
    return true;
  } catch (const CodecError& e) {
    if (error) *error = e.what();
    return false;
  }
}

}  // namespace rumi
