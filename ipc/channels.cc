#include "ipc/channels.h"

#include <spdlog/spdlog.h>

#include <cctype>
#include <cmath>
#include <chrono>

#include "ipc/byte_io.h"
#include "ipc/submap_codec.h"
#include "ipc/window_codec.h"

namespace rumi {

std::string InstanceIdProblem(const std::string& id) {
  if (id.empty() || id.size() > 32) return "instance id must have 1..32 characters";
  for (char c : id) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'))
      return "instance id '" + id + "' may only hold letters, digits, '_' and '-'";
  }
  return "";
}

const OptionSpec<IpcOptions>& IpcOptions::Spec() {
  using O = IpcOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("ipc");
    s->Text("instance", &O::instance, "segments are rumi_<instance>_<channel>; the command line's --instance wins",
            "[A-Za-z0-9_-]{1,32}", InstanceIdProblem);
    s->Number("window_slots", &O::window_slots, AtLeast(1), AtMost(64), "windows the front -> back ring holds");
    s->Number<int64_t>("window_slot_bytes", &O::window_slot_bytes, AtLeast<int64_t>(4096), AtMost<int64_t>(1ll << 30),
                       "bytes of one window slot (a whole window)");
    s->Number("submap_slots", &O::submap_slots, AtLeast(1), AtMost(1024), "submaps a submap ring holds");
    s->Number<int64_t>("submap_slot_bytes", &O::submap_slot_bytes, AtLeast<int64_t>(4096), AtMost<int64_t>(1ll << 30),
                       "bytes of one submap slot");
    s->Choice("overflow_policy", &O::overflow_policy, {"drop_newest", "drop_oldest"},
              "what a full ring drops");
    return s;
  }();
  return *spec;
}

bool IpcOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

OverflowPolicy IpcOptions::policy() const {
  OverflowPolicy p = OverflowPolicy::kDropNewest;
  ParseOverflowPolicy(overflow_policy, &p);
  return p;
}

const char* SubmapChannel(SubmapSource source) {
  if (source == SubmapSource::kFront) return kFrontSubmapChannel;
  if (source == SubmapSource::kBack) return kBackSubmapChannel;
  throw IpcError("merged submaps have no channel");
}

namespace {
RingLayout WindowLayout(const IpcOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw IpcError("bad IpcOptions: " + why);
  return {static_cast<uint64_t>(o.window_slots), static_cast<uint64_t>(o.window_slot_bytes), o.policy()};
}
// 64 frames of slack (2 s at 30 Hz) of 128 bytes; always the newest.
RingLayout PoseLayout() { return {64, 128, OverflowPolicy::kDropOldest}; }
RingLayout NoticeLayout() { return {16, 64, OverflowPolicy::kDropOldest}; }
constexpr uint32_t kNoticeMagic = 0x3254434e;  // "NCT2"
constexpr size_t kNoticeBytes = 4 + 8 + 8 + 4 + 8;
// The newest-wins rings: reads every unread message; decode(data, n) keeps
// the ones it accepts (true), so the last accepted is the newest. kOk if one
// was, else the ring's status.
template <typename F>
PopStatus ReadNewest(RingConsumer& ring, F&& decode) {
  bool got = false;
  for (;;) {
    const uint8_t* data = nullptr;
    size_t n = 0;
    const PopStatus st = ring.Peek(&data, &n, 0.0);
    if (st != PopStatus::kOk) return got ? PopStatus::kOk : st;
    got |= decode(data, n);
    ring.Release();
  }
}
constexpr uint32_t kPoseMagic = 0x31534f50;  // "POS1"
constexpr size_t kPoseBytes = 4 + 8 + 1 + 8 + 7 * 8;
RingLayout SubmapLayout(const IpcOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw IpcError("bad IpcOptions: " + why);
  return {static_cast<uint64_t>(o.submap_slots), static_cast<uint64_t>(o.submap_slot_bytes), o.policy()};
}
}  // namespace

WindowSender::WindowSender(const IpcOptions& o)
    : ring_(SegmentName(o.instance, kWindowChannel), WindowLayout(o)) {}

PushStatus WindowSender::Send(const ImageWindow& w) {
  const size_t n = EncodedWindowSize(w);
  const PushStatus st = ring_.Push(n, [&](uint8_t* dst) { EncodeWindowInto(w, dst, n); });
  if (st != PushStatus::kOk) {
    spdlog::debug("ipc {}: window {} ({} frames, {} bytes) {}", ring_.name(), w.id, w.frames.size(), n,
                  ToString(st));
  }
  return st;
}

WindowReceiver::WindowReceiver(const IpcOptions& o)
    : ring_(SegmentName(o.instance, kWindowChannel), WindowLayout(o)) {}

PopStatus WindowReceiver::PeekDecoded(ImageWindow* w, bool in_place, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const uint8_t* d = nullptr;
    size_t n = 0;
    const double left =
        std::max(0.0, std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count());
    const PopStatus st = ring_.Peek(&d, &n, left);
    if (st != PopStatus::kOk) return st;
    std::string err;
    if (DecodeWindow(d, n, w, in_place, &err)) return st;
    ++decode_errors_;
    spdlog::error("ipc {}: dropping undecodable window: {}", ring_.name(), err);
    ring_.Release();
  }
}

PopStatus WindowReceiver::Receive(ImageWindow* w, double timeout_s, bool hold) {
  const PopStatus st = PeekDecoded(w, false, timeout_s);
  if (st == PopStatus::kOk && !hold) ring_.Release();
  return st;
}

SubmapSender::SubmapSender(const IpcOptions& o, SubmapSource source)
    : ring_(SegmentName(o.instance, SubmapChannel(source)), SubmapLayout(o)) {}

PushStatus SubmapSender::Send(const Submap& s) {
  const size_t n = EncodedSubmapSize(s);
  const PushStatus st = ring_.Push(n, [&](uint8_t* dst) { EncodeSubmapInto(s, dst, n); });
  if (st != PushStatus::kOk) {
    spdlog::debug("ipc {}: submap {} ({} bytes) {}", ring_.name(), s.id, n, ToString(st));
  }
  return st;
}

SubmapReceiver::SubmapReceiver(const IpcOptions& o, SubmapSource source)
    : ring_(SegmentName(o.instance, SubmapChannel(source)), SubmapLayout(o)) {}

PopStatus SubmapReceiver::Receive(Submap* s, double timeout_s, bool hold) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const double left =
        std::max(0.0, std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count());
    const uint8_t* d = nullptr;
    size_t n = 0;
    const PopStatus st = ring_.Peek(&d, &n, left);
    if (st != PopStatus::kOk) return st;
    std::string err;
    if (DecodeSubmap(d, n, s, &err)) {
      if (!hold) ring_.Release();
      return st;
    }
    ++decode_errors_;
    spdlog::error("ipc {}: dropping undecodable submap: {}", ring_.name(), err);
    ring_.Release();
  }
}

PoseSender::PoseSender(const IpcOptions& o) : ring_(SegmentName(o.instance, kPoseChannel), PoseLayout()) {}

PushStatus PoseSender::Send(const FramePose& p) {
  return ring_.Push(kPoseBytes, [&](uint8_t* dst) {
    BufferWriter w(dst, kPoseBytes);
    w.Put(kPoseMagic);
    w.Put(p.timestamp);
    w.Put(static_cast<uint8_t>(p.state));
    w.Put(p.submap_id);
    const Eigen::Quaterniond& q = p.T_wc.rotation();
    for (double v : {p.T_wc.translation().x(), p.T_wc.translation().y(), p.T_wc.translation().z(), q.x(), q.y(),
                     q.z(), q.w()})
      w.Put(v);
  });
}

PoseReceiver::PoseReceiver(const IpcOptions& o) : ring_(SegmentName(o.instance, kPoseChannel), PoseLayout()) {}

PopStatus PoseReceiver::ReceiveNewest(FramePose* out) {
  return ReadNewest(ring_, [&](const uint8_t* data, size_t n) {
    FramePose p;
    bool ok = n == kPoseBytes;
    if (ok) {
      BufferReader r(data, n, "pose");
      double v[7];
      ok = r.Get<uint32_t>() == kPoseMagic;
      p.timestamp = r.Get<int64_t>();
      const uint8_t state = r.Get<uint8_t>();
      p.submap_id = r.Get<int64_t>();
      for (double& x : v) x = r.Get<double>();
      ok = ok && state <= static_cast<uint8_t>(TrackingState::kCoarse) &&
           std::abs(Eigen::Vector4d(v[3], v[4], v[5], v[6]).norm() - 1.0) < 1e-6;
      if (ok) {
        p.state = static_cast<TrackingState>(state);
        p.T_wc = Se3::FromUnitQuaternion(Eigen::Quaterniond(v[6], v[3], v[4], v[5]), Eigen::Vector3d(v[0], v[1], v[2]));
      }
    }
    if (!ok) {
      ++decode_errors_;
      return false;
    }
    *out = p;
    return true;
  });
}

MapNoticeSender::MapNoticeSender(const IpcOptions& o)
    : ring_(SegmentName(o.instance, kMapNoticeChannel), NoticeLayout()) {}

PushStatus MapNoticeSender::Send(const MapNotice& n) {
  return ring_.Push(kNoticeBytes, [&](uint8_t* dst) {
    BufferWriter w(dst, kNoticeBytes);
    w.Put(kNoticeMagic);
    w.Put(n.front_submap_upto);
    w.Put(n.front_submap_end);
    w.Put(n.components);
    w.Put(n.t);
  });
}

MapNoticeReceiver::MapNoticeReceiver(const IpcOptions& o)
    : ring_(SegmentName(o.instance, kMapNoticeChannel), NoticeLayout()) {}

PopStatus MapNoticeReceiver::ReceiveNewest(MapNotice* out) {
  return ReadNewest(ring_, [&](const uint8_t* data, size_t n) {
    if (n != kNoticeBytes) return false;
    BufferReader r(data, n, "map notice");
    if (r.Get<uint32_t>() != kNoticeMagic) return false;
    out->front_submap_upto = r.Get<int64_t>();
    out->front_submap_end = r.Get<Timestamp>();
    out->components = r.Get<int32_t>();
    out->t = r.Get<Timestamp>();
    return true;
  });
}

}  // namespace rumi
