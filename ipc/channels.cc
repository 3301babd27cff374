#include "ipc/channels.h"

#include <spdlog/spdlog.h>

#include <cctype>
#include <chrono>

#include "ipc/submap_codec.h"
#include "ipc/window_codec.h"

namespace rumi {

bool IpcOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (instance.empty() || instance.size() > 32) return fail("instance id must have 1..32 characters");
  for (char c : instance) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) {
      return fail("instance id '" + instance + "' may only hold letters, digits, '_' and '-'");
    }
  }
  if (window_slots < 1 || window_slots > 64) return fail("window_slots must be in [1, 64]");
  if (submap_slots < 1 || submap_slots > 1024) return fail("submap_slots must be in [1, 1024]");
  constexpr int64_t kMin = 4096, kMax = 1ll << 30;
  if (window_slot_bytes < kMin || window_slot_bytes > kMax) return fail("window_slot_bytes must be in [4 KiB, 1 GiB]");
  if (submap_slot_bytes < kMin || submap_slot_bytes > kMax) return fail("submap_slot_bytes must be in [4 KiB, 1 GiB]");
  OverflowPolicy p;
  if (!ParseOverflowPolicy(overflow_policy, &p)) {
    return fail("overflow_policy '" + overflow_policy + "' is neither drop_newest nor drop_oldest");
  }
  return true;
}

OverflowPolicy IpcOptions::policy() const {
  OverflowPolicy p = OverflowPolicy::kDropNewest;
  ParseOverflowPolicy(overflow_policy, &p);
  return p;
}

void ReadOptions(ConfigSection& s, IpcOptions* o) {
  s.Read("instance", &o->instance);
  s.ReadInRange("window_slots", &o->window_slots, 1, 64);
  s.ReadInRange<int64_t>("window_slot_bytes", &o->window_slot_bytes, 4096, 1ll << 30);
  s.ReadInRange("submap_slots", &o->submap_slots, 1, 1024);
  s.ReadInRange<int64_t>("submap_slot_bytes", &o->submap_slot_bytes, 4096, 1ll << 30);
  s.Read("overflow_policy", &o->overflow_policy);
  std::string why;
  OverflowPolicy p;
  if (!o->Check(&why)) s.Fail(ParseOverflowPolicy(o->overflow_policy, &p) ? "instance" : "overflow_policy", why);
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

PopStatus WindowReceiver::Receive(ImageWindow* w, double timeout_s) {
  const PopStatus st = PeekDecoded(w, false, timeout_s);
  if (st == PopStatus::kOk) ring_.Release();
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

PopStatus SubmapReceiver::Receive(Submap* s, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const double left =
        std::max(0.0, std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count());
    bool ok = false;
    std::string err;
    const PopStatus st = ring_.Pop([&](const uint8_t* d, size_t n) { ok = DecodeSubmap(d, n, s, &err); }, left);
    if (st != PopStatus::kOk || ok) return st;
    ++decode_errors_;
    spdlog::error("ipc {}: dropping undecodable submap: {}", ring_.name(), err);
  }
}

}  // namespace rumi
