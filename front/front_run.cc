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

int RunFront(const FrontRunOptions& o, const std::atomic<bool>* stop) {
  if (o.publisher.out_dir.empty()) {
    spdlog::error("front: no output folder (--out)");
    return kExitBadInput;
  }
  std::unique_ptr<FrameStream> stream;
  try {
    stream = OpenFrameStream(o.stream);
  } catch (const StreamError& e) {
    spdlog::error("front: cannot open the source: {}", e.what());
    return kExitBadInput;
  }
  Trajectory odometry;
  if (!o.stream.source.odometry.empty()) {
    try {
      odometry = ReadTumTrajectory(o.stream.source.odometry);
    } catch (const std::exception& e) {
      spdlog::error("front: odometry: {}", e.what());
      return kExitBadInput;
    }
    if (odometry.empty()) {
      spdlog::error("front: odometry {}: no poses", o.stream.source.odometry);
      return kExitBadInput;
    }
  }

  std::optional<ImuReplay> imu_file;
  if (!o.stream.source.imu.empty()) {
    try {
      imu_file.emplace(ReadImuCsv(o.stream.source.imu));
    } catch (const std::exception& e) {
      spdlog::error("front: imu: {}", e.what());
      return kExitBadInput;
    }
  }

  // The front's own stop flag: the caller's (mirrored here every 20 ms, so a
  // stream waiting for a camera that is down notices a SIGTERM too).
  std::atomic<bool> stop_flag{false}, done{false};
  std::thread mirror([&] {
    while (!done.load()) {
      if (stop && stop->load()) stop_flag.store(true);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  struct JoinMirror {
    std::atomic<bool>* done;
    std::thread* t;
    ~JoinMirror() {
      done->store(true);
      t->join();
    }
  } join_mirror{&done, &mirror};
  auto stopped = [&] { return stop_flag.load() || (stop && stop->load()); };
  cv::setNumThreads(1);  // shared cores: OpenCV threads would fight tracking + mapping
  size_t n = 0, used = 0;
  const auto run_start = std::chrono::steady_clock::now();
  std::mutex halt_mutex;  // halt_stats, gyro_stats: the tracking thread writes, the publisher reads
  HaltStats halt_stats;
  Front::GyroStats gyro_stats;
  try {
    Front front(o.front, stream->camera(), o.first_submap_id);
    front.LimitHistory(1);  // the publisher logs every frame; a day-long run must not grow
    FrontPublisherOptions popt = o.publisher;
    popt.first_window_id = o.first_submap_id;
    FrontPublisher pub(popt, o.ipc, o.sampler, stream->camera().options());
    FrameStream* source = stream.get();
    pub.SetSourceStatus([source] { return source->Status(); });
    // Hierarchical mode over the robot link: the robot halts while its
    // finished submap merges (HaltControl, the manager's map notices).
    const bool halting = o.front.hierarchical && stream->can_halt();
    HaltControl halt(o.stream.source.link.max_halt_s);
    std::unique_ptr<MapNoticeReceiver> notices;
    if (halting) notices = std::make_unique<MapNoticeReceiver>(o.ipc);
    MapNotice map_notice;
    // finished_id >= 0: the front just finished that submap (its last frame
    // at finished_end); the newest map notice says whether the map has it.
    auto update_halt = [&](int64_t finished_id, Timestamp finished_end) {
      notices->ReceiveNewest(&map_notice);  // keeps the last one when there is none new
      const bool want = halt.Update(finished_id, finished_end, map_notice.front_submap_upto,
                                    map_notice.front_submap_end, SecondsSince(run_start));
      stream->SetHalt(want);
      std::lock_guard<std::mutex> l(halt_mutex);
      halt_stats = halt.stats();
    };
    // A halted robot may send no frame until it walks again: the merge that
    // ends the halt is also looked for while the stream waits.
    if (halting) stream->SetIdle([&] {
        if (halt.halted()) update_halt(-1, 0);
      });
    pub.SetSourceDetail([source, halting, &halt_mutex, &halt_stats, &gyro_stats] {
      nlohmann::json d = source->Detail();
      if (d.is_object()) {  // what the front made of the link's IMU
        std::lock_guard<std::mutex> l(halt_mutex);
        if (gyro_stats.predicted + gyro_stats.bias_updates > 0 || gyro_stats.disabled)
          d["gyro"] = {{"predicted", gyro_stats.predicted},
                       {"bridged", gyro_stats.bridged},
                       {"bias_updates", gyro_stats.bias_updates},
                       {"bias", {gyro_stats.bias.x(), gyro_stats.bias.y(), gyro_stats.bias.z()}},
                       {"disabled", gyro_stats.disabled}};
      }
      if (halting && d.is_object()) {
        std::lock_guard<std::mutex> l(halt_mutex);
        d["halts"] = {{"halts", halt_stats.halts},
                      {"resumed_on_merge", halt_stats.resumed_on_merge},
                      {"resumed_on_timeout", halt_stats.resumed_on_timeout},
                      {"longest_s", halt_stats.longest_halt_s}};
      }
      return d;
    });
    spdlog::info("front: {}, instance {}, out {}{}", stream->Describe(), o.ipc.instance, popt.out_dir,
                 o.first_submap_id ? ", first submap id " + std::to_string(o.first_submap_id) : "");
    if (!odometry.empty())
      spdlog::info("front: pose source {} ({} poses)", o.stream.source.odometry, odometry.size());
    if (imu_file) spdlog::info("front: IMU {} ({} samples)", o.stream.source.imu, imu_file->size());
    Notifier notifier;
    notifier.Ready();
    const std::function<Submap()> snapshot = [&front] { return front.CurrentSubmap(); };
    Frame frame;
    std::vector<Timestamp> skipped;
    size_t next_odometry = 0;
    Timestamp odometry_offset = 0;
    bool bad_input = false;
    for (;;) {
      if (stopped()) stop_flag.store(true);
      skipped.clear();
      bool got = false;
      try {
        got = stream->Next(&frame, &skipped, &stop_flag);
      } catch (const StreamError& e) {
        spdlog::error("front: {}", e.what());
        bad_input = true;
        break;
      }
      for (Timestamp t : skipped) {
        if (o.max_frames > 0 && n >= static_cast<size_t>(o.max_frames)) break;
        pub.OnSkipped(t);
        ++n;
      }
      if (stopped() && !stop_flag.load()) stop_flag.store(true);
      if (!got || stopped() || (o.max_frames > 0 && n >= static_cast<size_t>(o.max_frames))) break;
      // The pose source as a robot would deliver it: every pose up to the
      // frame and the next one, so the frame's pose can be interpolated. A
      // looped dataset shifts its poses with its frames.
      if (!odometry.empty()) {
        if (stream->timestamp_offset() != odometry_offset) {
          odometry_offset = stream->timestamp_offset();
          next_odometry = 0;
        }
        while (next_odometry < odometry.size() &&
               (next_odometry == 0 || odometry[next_odometry - 1].t + odometry_offset <= frame.timestamp)) {
          front.AddPosePrior(odometry[next_odometry].t + odometry_offset, odometry[next_odometry].T_wc);
          ++next_odometry;
        }
      }
      // The IMU: a live source's samples so far, or a file's up to the frame.
      for (const ImuSample& s : stream->TakeImu()) front.AddImu(s.t, s.gyro);
      if (imu_file)
        for (const ImuSample& s : imu_file->Until(frame.timestamp, stream->timestamp_offset())) front.AddImu(s.t, s.gyro);
      const int64_t submap_before = front.current_submap_id();
      const bool coarse_before = front.halt();
      const FrameRecord rec = front.Track(frame.timestamp, frame.image);
      if (halting) {
        const auto& fin = front.FinishedSubmaps();
        const bool finished = !coarse_before && front.halt() && !fin.empty() && fin.back().id == submap_before;
        const Timestamp finished_end = finished && !fin.back().frames.empty() ? fin.back().frames.back().timestamp : 0;
        update_halt(finished ? submap_before : -1, finished_end);
      }
      {
        std::lock_guard<std::mutex> l(halt_mutex);
        gyro_stats = front.gyro_stats();
      }
      const FrameTiming& tm = front.timings().back();
      pub.OnFrame(rec, frame.image, tm.total_ms, tm.cpu_ms, front.current_submap_keyframes(), front.FinishedSubmaps(),
                  snapshot);
      front.TrimFinished(pub.finished_taken());  // the publisher holds its copies
      ++n;
      ++used;
    }
    if (halting) {
      stream->SetIdle(nullptr);
      stream->SetHalt(false);  // never leave the robot standing
      spdlog::info("front: robot link: {}", halt.Describe());
    }
    const bool by_signal = stop && stop->load();
    if (by_signal) spdlog::info("front: stop requested after {} frames: finishing", n);
    front.Finish();
    notifier.Stopping();
    if (!pub.Finish(front.FinishedSubmaps(), by_signal)) return kExitError;
    if (const std::string g = front.GyroSummary(); !g.empty()) spdlog::info("front: {}", g);
    spdlog::info("front: done: {} frames ({} tracked by the front), {} passed over by the stream, {} unreadable, "
                 "{} submaps",
                 n, used, n - used, stream->unreadable(), front.FinishedSubmaps().size());
    if (bad_input) return kExitBadInput;
    if (by_signal) return kExitStopped;
    if (used == 0) {
      spdlog::error("front: not one frame reached the front ({} listed frames passed over, {} unreadable)", n - used,
                    stream->unreadable());
      return kExitNothingProcessed;
    }
    return kExitDone;
  } catch (const IpcError& e) {
    spdlog::error("front: ipc: {}", e.what());
    return kExitError;
  } catch (const std::exception& e) {
    spdlog::error("front: {}", e.what());
    return kExitError;
  }
}

}  // namespace rumi
