#pragma once
// The three rumi channels on top of the shared-memory ring:
//   windows        front -> back     ImageWindow  (ipc/window_codec)
//   front_submaps  front -> manager  Submap       (ipc/submap_codec)
//   back_submaps   back  -> manager  Submap
//   poses          front -> manager  FramePose (every frame; the newest wins)
//   map_notices    manager -> front  MapNotice (after every rebuild; the newest wins)
// Segment names are rumi_<instance>_<channel>, so instances run side by side.
#include <memory>
#include <string>

#include "common/option_spec.h"
#include "common/submap.h"
#include "common/window.h"
#include "ipc/shm_ring.h"

namespace rumi {

struct IpcOptions {
  std::string instance = "default";  // [A-Za-z0-9_-], at most 32 characters
  int window_slots = 3;
  // One slot holds a whole window: ~ (len + max_s2 + S3) grey images. 48 MiB
  // is ~160 VGA frames. Segments are tmpfs pages: only unread messages use
  // RAM (the consumer frees a large message's pages on release).
  int64_t window_slot_bytes = 48ll << 20;
  int submap_slots = 4;
  int64_t submap_slot_bytes = 96ll << 20;  // a 200-keyframe ORB submap encodes to ~20 MB
  std::string overflow_policy = "drop_newest";  // or "drop_oldest"
  static const OptionSpec<IpcOptions>& Spec();  // section `ipc:`
  bool Check(std::string* why = nullptr) const;
  OverflowPolicy policy() const;
};
// "" when id is a usable instance id, else why not.
std::string InstanceIdProblem(const std::string& id);

constexpr const char* kWindowChannel = "windows";
constexpr const char* kFrontSubmapChannel = "front_submaps";
constexpr const char* kBackSubmapChannel = "back_submaps";
constexpr const char* kPoseChannel = "poses";
constexpr const char* kMapNoticeChannel = "map_notices";
const char* SubmapChannel(SubmapSource source);  // kFront / kBack (kMerged is never sent)

class WindowSender {
 public:
  explicit WindowSender(const IpcOptions& o);
  // Serialises w straight into a ring slot; never waits.
  PushStatus Send(const ImageWindow& w);
  RingProducer& ring() { return ring_; }

 private:
  RingProducer ring_;
};

class WindowReceiver {
 public:
  explicit WindowReceiver(const IpcOptions& o);
  // Deep-copied window. kOk, kEmpty after timeout_s, kNotConnected, kIncompatible.
  // A record that fails to decode is logged, counted and skipped. With
  // `hold`, the message stays in its slot until Release(): a consumer that
  // dies before it gets it again when it attaches anew.
  PopStatus Receive(ImageWindow* w, double timeout_s = 0.0, bool hold = false);
  void Release() { ring_.Release(); }
  // Zero-copy: f(const ImageWindow&) sees images pointing into the slot; they
  // are valid only during the call.
  template <typename F>
  PopStatus ReceiveInPlace(F&& f, double timeout_s = 0.0) {
    ImageWindow w;
    const PopStatus st = PeekDecoded(&w, true, timeout_s);
    if (st == PopStatus::kOk) {
      f(static_cast<const ImageWindow&>(w));
      ring_.Release();
    }
    return st;
  }
  uint64_t decode_errors() const { return decode_errors_; }
  RingConsumer& ring() { return ring_; }

 private:
  PopStatus PeekDecoded(ImageWindow* w, bool in_place, double timeout_s);
  RingConsumer ring_;
  uint64_t decode_errors_ = 0;
};

class SubmapSender {
 public:
  SubmapSender(const IpcOptions& o, SubmapSource source);
  PushStatus Send(const Submap& s);
  RingProducer& ring() { return ring_; }

 private:
  RingProducer ring_;
};

class SubmapReceiver {
 public:
  SubmapReceiver(const IpcOptions& o, SubmapSource source);
  // With `hold`: the message stays in its slot until Release() (see WindowReceiver).
  PopStatus Receive(Submap* s, double timeout_s = 0.0, bool hold = false);
  void Release() { ring_.Release(); }
  uint64_t decode_errors() const { return decode_errors_; }
  RingConsumer& ring() { return ring_; }

 private:
  RingConsumer ring_;
  uint64_t decode_errors_ = 0;
};

// The front's pose of one frame, in its submap's frame, for the live pose
// stream (rumi-manager serves it over DDS). A small fixed-size message on a
// ring that overwrites its oldest: the tracking thread never waits, and a
// reader that falls behind skips to the newest.
struct FramePose {
  Timestamp timestamp = 0;
  TrackingState state = TrackingState::kInitializing;
  int64_t submap_id = -1;
  Se3 T_wc;  // camera -> submap frame; identity unless tracking or coarse
};

class PoseSender {
 public:
  explicit PoseSender(const IpcOptions& o);
  PushStatus Send(const FramePose& p);  // never waits
  RingProducer& ring() { return ring_; }

 private:
  RingProducer ring_;
};

class PoseReceiver {
 public:
  explicit PoseReceiver(const IpcOptions& o);
  // The newest unread pose (older unread ones are skipped): kOk, kEmpty,
  // kNotConnected (no front yet), kIncompatible. A malformed record is
  // counted and skipped.
  PopStatus ReceiveNewest(FramePose* p);
  uint64_t decode_errors() const { return decode_errors_; }

 private:
  RingConsumer ring_;
  uint64_t decode_errors_ = 0;
};

// What the manager has built, for the front: after every rebuild, the newest
// front submap the global map now holds. The front halts the robot on
// entering the coarse state and resumes it once its finished submap is in
// the map (the rat-robot paper's halt while the submaps merge). Same ring
// shape as the poses: the manager never waits, the front reads the newest.
struct MapNotice {
  int64_t front_submap_upto = -1;  // highest front submap id in the map (-1: none)
  Timestamp front_submap_end = 0;  // its last frame (a snapshot of one being built ends earlier)
  int32_t components = 0;
  Timestamp t = 0;                 // wall clock of the rebuild's end
};

class MapNoticeSender {
 public:
  explicit MapNoticeSender(const IpcOptions& o);
  PushStatus Send(const MapNotice& n);  // never waits

 private:
  RingProducer ring_;
};

class MapNoticeReceiver {
 public:
  explicit MapNoticeReceiver(const IpcOptions& o);
  // The newest unread notice: kOk, kEmpty, kNotConnected (no manager yet).
  PopStatus ReceiveNewest(MapNotice* n);

 private:
  RingConsumer ring_;
};

}  // namespace rumi
