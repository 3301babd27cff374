#include "front/front_run.h"

#include <opencv2/core.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "common/process/exit_codes.h"
#include "common/process/notify.h"
#include "common/trajectory.h"
#include "front/front.h"
#include "front/halt_control.h"

namespace rumi {
namespace {

// What the front reads before its first frame.
struct Inputs {
  std::unique_ptr<FrameStream> stream;
  Trajectory odometry;             // the pose source's file (empty: none)
  std::optional<ImuReplay> imu;    // the IMU file (none: no file)
};

// False (logged): bad input, the stream or a file cannot be read.
bool OpenInputs(const FrontRunOptions& o, Inputs* in) {
  try {
    in->stream = OpenFrameStream(o.stream);
  } catch (const StreamError& e) {
    spdlog::error("front: cannot open the source: {}", e.what());
    return false;
  }
  if (!o.stream.source.odometry.empty()) {
    try {
      in->odometry = ReadTumTrajectory(o.stream.source.odometry);
    } catch (const std::exception& e) {
      spdlog::error("front: odometry: {}", e.what());
      return false;
    }
    if (in->odometry.empty()) {
      spdlog::error("front: odometry {}: no poses", o.stream.source.odometry);
      return false;
    }
  }
  if (!o.stream.source.imu.empty()) {
    try {
      in->imu.emplace(ReadImuCsv(o.stream.source.imu));
    } catch (const std::exception& e) {
      spdlog::error("front: imu: {}", e.what());
      return false;
    }
  }
  return true;
}

// The front's own stop flag: the caller's (mirrored here every 20 ms, so a
// stream waiting for a camera that is down notices a SIGTERM too).
class StopMirror {
 public:
  explicit StopMirror(const std::atomic<bool>* stop) : stop_(stop), thread_([this] {
    while (!done_.load()) {
      if (stop_ && stop_->load()) flag_.store(true);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }) {}
  ~StopMirror() {
    done_.store(true);
    thread_.join();
  }
  std::atomic<bool>* flag() { return &flag_; }
  bool stopped() const { return flag_.load() || by_signal(); }
  bool by_signal() const { return stop_ && stop_->load(); }  // the caller's stop

 private:
  const std::atomic<bool>* stop_;
  std::atomic<bool> flag_{false}, done_{false};
  std::thread thread_;  // last: starts once the flags above exist
};

// The source's detail in the publisher's status, with what the front made of
// the link's IMU and the robot's halts: the tracking thread writes, the
// publisher's thread reads.
class SourceDetail {
 public:
  void SetGyro(const Front::GyroStats& g) {
    std::lock_guard<std::mutex> l(mutex_);
    gyro_ = g;
  }
  void SetHalts(const HaltStats& h) {
    std::lock_guard<std::mutex> l(mutex_);
    halts_ = h;
  }
  nlohmann::json Of(FrameStream* source, bool halting) {
    nlohmann::json d = source->Detail();
    if (d.is_object()) {
      std::lock_guard<std::mutex> l(mutex_);
      if (gyro_.predicted + gyro_.bias_updates > 0 || gyro_.disabled)
        d["gyro"] = {{"predicted", gyro_.predicted},
                     {"bridged", gyro_.bridged},
                     {"bias_updates", gyro_.bias_updates},
                     {"bias", {gyro_.bias.x(), gyro_.bias.y(), gyro_.bias.z()}},
                     {"disabled", gyro_.disabled}};
    }
    if (halting && d.is_object()) {
      std::lock_guard<std::mutex> l(mutex_);
      d["halts"] = {{"halts", halts_.halts},
                    {"resumed_on_merge", halts_.resumed_on_merge},
                    {"resumed_on_timeout", halts_.resumed_on_timeout},
                    {"longest_s", halts_.longest_halt_s}};
    }
    return d;
  }

 private:
  std::mutex mutex_;
  HaltStats halts_;
  Front::GyroStats gyro_;
};

// Hierarchical mode over the robot link: the robot halts while its finished
// submap merges (HaltControl, the manager's map notices). Does nothing when
// the mode is off or the stream cannot halt its source.
class RobotHalt {
 public:
  RobotHalt(const FrontRunOptions& o, FrameStream* stream, SourceDetail* detail,
            std::chrono::steady_clock::time_point run_start)
      : halting_(o.front.hierarchical && stream->can_halt()), stream_(stream), detail_(detail),
        halt_(o.stream.source.link.max_halt_s), run_start_(run_start) {
    if (!halting_) return;
    notices_ = std::make_unique<MapNoticeReceiver>(o.ipc);
    // A halted robot may send no frame until it walks again: the merge that
    // ends the halt is also looked for while the stream waits.
    stream_->SetIdle([this] {
      if (halt_.halted()) Update(-1, 0);
    });
  }
  bool halting() const { return halting_; }

  // After each frame: did the front just finish the submap it was building?
  void AfterFrame(const Front& front, int64_t submap_before, bool coarse_before) {
    if (!halting_) return;
    const auto& fin = front.FinishedSubmaps();
    const bool finished = !coarse_before && front.halt() && !fin.empty() && fin.back().id == submap_before;
    const Timestamp finished_end = finished && !fin.back().frames.empty() ? fin.back().frames.back().timestamp : 0;
    Update(finished ? submap_before : -1, finished_end);
  }

  // Never leave the robot standing.
  void End() {
    if (!halting_) return;
    stream_->SetIdle(nullptr);
    stream_->SetHalt(false);
    spdlog::info("front: robot link: {}", halt_.Describe());
  }

 private:
  // finished_id >= 0: the front just finished that submap (its last frame
  // at finished_end); the newest map notice says whether the map has it.
  void Update(int64_t finished_id, Timestamp finished_end) {
    notices_->ReceiveNewest(&map_notice_);  // keeps the last one when there is none new
    const bool want = halt_.Update(finished_id, finished_end, map_notice_.front_submap_upto,
                                   map_notice_.front_submap_end, SecondsSince(run_start_));
    stream_->SetHalt(want);
    detail_->SetHalts(halt_.stats());
  }

  const bool halting_;
  FrameStream* stream_;
  SourceDetail* detail_;
  HaltControl halt_;
  std::unique_ptr<MapNoticeReceiver> notices_;
  MapNotice map_notice_;
  std::chrono::steady_clock::time_point run_start_;
};

// The pose source as a robot would deliver it: every pose up to the frame
// and the next one, so the frame's pose can be interpolated. A looped
// dataset shifts its poses with its frames. The IMU: a live source's samples
// so far, or a file's up to the frame.
class PriorFeed {
 public:
  explicit PriorFeed(Inputs* in) : in_(in) {}
  void Before(Timestamp frame_t, Front* front) {
    FrameStream* stream = in_->stream.get();
    const Trajectory& odometry = in_->odometry;
    if (!odometry.empty()) {
      if (stream->timestamp_offset() != offset_) {
        offset_ = stream->timestamp_offset();
        next_ = 0;
      }
      while (next_ < odometry.size() && (next_ == 0 || odometry[next_ - 1].t + offset_ <= frame_t)) {
        front->AddPosePrior(odometry[next_].t + offset_, odometry[next_].T_wc);
        ++next_;
      }
    }
    for (const ImuSample& s : stream->TakeImu()) front->AddImu(s.t, s.gyro);
    if (in_->imu)
      for (const ImuSample& s : in_->imu->Until(frame_t, stream->timestamp_offset())) front->AddImu(s.t, s.gyro);
  }

 private:
  Inputs* in_;
  size_t next_ = 0;
  Timestamp offset_ = 0;
};

struct Counts {
  size_t n = 0, used = 0;  // frames listed (delivered + passed over), frames the front tracked
  bool bad_input = false;  // the stream failed
};

// Frames through the front and out to the publisher until the stream ends,
// the stop flag is set or max_frames are listed.
Counts TrackFrames(const FrontRunOptions& o, Inputs* in, Front* front, FrontPublisher* pub, RobotHalt* halt,
                   SourceDetail* detail, StopMirror* stop) {
  FrameStream* stream = in->stream.get();
  const std::function<Submap()> snapshot = [front] { return front->CurrentSubmap(); };
  PriorFeed priors(in);
  Counts c;
  const auto enough = [&] { return o.max_frames > 0 && c.n >= static_cast<size_t>(o.max_frames); };
  Frame frame;
  std::vector<Timestamp> skipped;
  for (;;) {
    if (stop->stopped()) stop->flag()->store(true);
    skipped.clear();
    bool got = false;
    try {
      got = stream->Next(&frame, &skipped, stop->flag());
    } catch (const StreamError& e) {
      spdlog::error("front: {}", e.what());
      c.bad_input = true;
      break;
    }
    for (Timestamp t : skipped) {
      if (enough()) break;
      pub->OnSkipped(t);
      ++c.n;
    }
    if (stop->stopped() && !stop->flag()->load()) stop->flag()->store(true);
    if (!got || stop->stopped() || enough()) break;
    priors.Before(frame.timestamp, front);
    const int64_t submap_before = front->current_submap_id();
    const bool coarse_before = front->halt();
    const FrameRecord rec = front->Track(frame.timestamp, frame.image);
    halt->AfterFrame(*front, submap_before, coarse_before);
    detail->SetGyro(front->gyro_stats());
    const FrameTiming& tm = front->timings().back();
    pub->OnFrame(rec, frame.image, tm.total_ms, tm.cpu_ms, front->current_submap_keyframes(),
                 front->FinishedSubmaps(), snapshot);
    front->TrimFinished(pub->finished_taken());  // the publisher holds its copies
    ++c.n;
    ++c.used;
  }
  return c;
}

void LogStart(const FrontRunOptions& o, const Inputs& in, const std::string& out_dir) {
  spdlog::info("front: {}, instance {}, out {}{}", in.stream->Describe(), o.ipc.instance, out_dir,
               o.first_submap_id ? ", first submap id " + std::to_string(o.first_submap_id) : "");
  if (!in.odometry.empty())
    spdlog::info("front: pose source {} ({} poses)", o.stream.source.odometry, in.odometry.size());
  if (in.imu) spdlog::info("front: IMU {} ({} samples)", o.stream.source.imu, in.imu->size());
}

// The end of the run: the last submap out, the files written; the exit code.
int FinishRun(Front* front, FrontPublisher* pub, Notifier* notifier, const FrameStream& stream, const Counts& c,
              bool by_signal) {
  if (by_signal) spdlog::info("front: stop requested after {} frames: finishing", c.n);
  front->Finish();
  notifier->Stopping();
  if (!pub->Finish(front->FinishedSubmaps(), by_signal)) return kExitError;
  if (const std::string g = front->GyroSummary(); !g.empty()) spdlog::info("front: {}", g);
  spdlog::info("front: done: {} frames ({} tracked by the front), {} passed over by the stream, {} unreadable, "
               "{} submaps",
               c.n, c.used, c.n - c.used, stream.unreadable(), front->FinishedSubmaps().size());
  if (c.bad_input) return kExitBadInput;
  if (by_signal) return kExitStopped;
  if (c.used == 0) {
    spdlog::error("front: not one frame reached the front ({} listed frames passed over, {} unreadable)",
                  c.n - c.used, stream.unreadable());
    return kExitNothingProcessed;
  }
  return kExitDone;
}

// The front and its publisher over the opened inputs; throws on IPC errors.
int Run(const FrontRunOptions& o, Inputs* in, StopMirror* stop) {
  const auto run_start = std::chrono::steady_clock::now();
  FrameStream* source = in->stream.get();
  SourceDetail detail;  // before the publisher, whose thread reads it
  Front front(o.front, source->camera(), o.first_submap_id);
  front.LimitHistory(1);  // the publisher logs every frame; a day-long run must not grow
  FrontPublisherOptions popt = o.publisher;
  popt.first_window_id = o.first_submap_id;
  FrontPublisher pub(popt, o.ipc, o.sampler, source->camera().options());
  pub.SetSourceStatus([source] { return source->Status(); });
  RobotHalt halt(o, source, &detail, run_start);
  pub.SetSourceDetail([source, &detail, halting = halt.halting()] { return detail.Of(source, halting); });
  LogStart(o, *in, popt.out_dir);
  Notifier notifier;
  notifier.Ready();
  const Counts c = TrackFrames(o, in, &front, &pub, &halt, &detail, stop);
  halt.End();
  return FinishRun(&front, &pub, &notifier, *source, c, stop->by_signal());
}

}  // namespace

int RunFront(const FrontRunOptions& o, const std::atomic<bool>* stop) {
  if (o.publisher.out_dir.empty()) {
    spdlog::error("front: no output folder (--out)");
    return kExitBadInput;
  }
  Inputs in;
  if (!OpenInputs(o, &in)) return kExitBadInput;
  StopMirror stop_mirror(stop);
  cv::setNumThreads(1);  // shared cores: OpenCV threads would fight tracking + mapping
  try {
    return Run(o, &in, &stop_mirror);
  } catch (const IpcError& e) {
    spdlog::error("front: ipc: {}", e.what());
    return kExitError;
  } catch (const std::exception& e) {
    spdlog::error("front: {}", e.what());
    return kExitError;
  }
}

}  // namespace rumi
