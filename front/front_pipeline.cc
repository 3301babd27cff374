#include "front/front_pipeline.h"

#include <opencv2/core.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <csignal>
#include <functional>
#include <exception>
#include <memory>
#include <vector>

#include "common/camera_config.h"
#include "common/config.h"
#include "common/dataset.h"
#include "common/logging.h"
#include "common/trajectory.h"
#include "front/frame_replay.h"
#include "front/front.h"
#include "front/front_options.h"
#include "front/front_publisher.h"
#include "front/sampler.h"
#include "ipc/channels.h"

namespace rumi {
namespace {

std::atomic<bool> g_signal_stop{false};
void OnSignal(int) { g_signal_stop.store(true); }

// SetupLogging registers the logger "front" and must run once per process;
// tests run the pipeline several times, a main may have set it up already.
bool SetupFrontLogging(const std::string& level) {
  if (!spdlog::get("front")) return SetupLogging("front", level);
  const auto lvl = spdlog::level::from_str(level);
  if (lvl == spdlog::level::off && level != "off") return false;
  spdlog::set_level(lvl);
  return true;
}

struct PipelineConfig {
  FrontOptions front;
  SamplerOptions sampler;
  IpcOptions ipc;
  std::string log_level = "info";
};

// Throws ConfigError naming file and key.
void ReadPipelineConfig(const std::string& path, PipelineConfig* c) {
  if (path.empty()) return;
  ConfigSection root = LoadConfigFile(path);
  ConfigSection f = root.Child("front");
  ReadOptions(f, &c->front);
  CheckOptions(c->front, root, "front");
  ConfigSection s = root.Child("sampler");
  ReadOptions(s, &c->sampler);
  CheckOptions(c->sampler, root, "sampler");
  ConfigSection i = root.Child("ipc");
  ReadOptions(i, &c->ipc);
  if (root.Has("camera")) {  // applied by OpenDataset (config_path); checked here so a typo is exit 2
    ConfigSection cam = root.Child("camera");
    PinholeCameraOptions unused;
    ReadOptions(cam, &unused);
  }
  root.Read("log_level", &c->log_level);
  for (const char* other : {"back", "manager"}) root.Ignore(other);
  root.Finish();
}

class SignalGuard {
 public:
  explicit SignalGuard(bool install) : installed_(install) {
    if (!install) return;
    g_signal_stop.store(false);
    struct sigaction sa {};
    sa.sa_handler = OnSignal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~SignalGuard() {
    if (!installed_) return;
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }

 private:
  bool installed_;
  struct sigaction old_int_ {}, old_term_ {};
};

}  // namespace

int RunFrontPipeline(const FrontPipelineArgs& a) {
  PipelineConfig cfg;
  try {
    ReadPipelineConfig(a.config_path, &cfg);
  } catch (const ConfigError& e) {
    SetupFrontLogging(a.log_level.empty() ? "info" : a.log_level);
    spdlog::error("{}", e.what());
    return 2;
  }
  const std::string level = a.log_level.empty() ? cfg.log_level : a.log_level;
  if (!SetupFrontLogging(level)) spdlog::warn("unknown log level '{}'", level);

  DatasetOptions dopt;
  if (!ParseDatasetKind(a.dataset_kind, &dopt.kind)) {
    spdlog::error("unknown dataset kind '{}' (tum|euroc|icl|kitti|folder)", a.dataset_kind);
    return 2;
  }
  dopt.path = a.dataset_path;
  dopt.config_path = a.config_path;
  FrameReplayOptions ropt;
  if (!ParseReplayRate(a.rate, &ropt)) {
    spdlog::error("--rate '{}': expected a positive number or max", a.rate);
    return 2;
  }
  if (a.out_dir.empty() || a.instance.empty()) {
    spdlog::error("the pipeline needs --out RUNDIR and --instance ID");
    return 2;
  }
  cfg.ipc.instance = a.instance;
  std::string why;
  if (!cfg.ipc.Check(&why)) {
    spdlog::error("--instance '{}' / ipc config: {}", a.instance, why);
    return 2;
  }
  FrontPublisherOptions popt;
  popt.out_dir = a.out_dir;
  popt.resend_interval_s = a.resend_interval_s;
  popt.wait_for_consumers_s = a.wait_for_consumers_s;
  if (!popt.Check(&why)) {
    spdlog::error("{}", why);
    return 2;
  }
  std::unique_ptr<FrameSource> source;
  try {
    source = OpenDataset(dopt);
  } catch (const std::exception& e) {
    spdlog::error("cannot open dataset: {}", e.what());
    return 2;
  }

  Trajectory odometry;
  if (!a.odometry_path.empty()) {
    try {
      odometry = ReadTumTrajectory(a.odometry_path);
    } catch (const std::exception& e) {
      spdlog::error("--odometry: {}", e.what());
      return 2;
    }
    if (odometry.empty()) {
      spdlog::error("--odometry {}: no poses", a.odometry_path);
      return 2;
    }
  }

  SignalGuard signals(a.install_signal_handlers);
  auto stopped = [&] { return g_signal_stop.load() || (a.stop && a.stop->load()); };
  // FrameReplay polls one flag while it sleeps; mirror both sources into it.
  std::atomic<bool> stop_flag{false};
  cv::setNumThreads(1);  // shared cores: OpenCV threads would fight tracking + mapping
  try {
    Front front(cfg.front, source->camera());
    FrontPublisher pub(popt, cfg.ipc, cfg.sampler, source->camera().options());
    spdlog::info("front pipeline: {} frames ({}), instance {}, rate {}, out {}", source->size(), a.dataset_path,
                 a.instance, ropt.max ? std::string("max") : std::to_string(ropt.rate), a.out_dir);
    if (!odometry.empty())
      spdlog::info("front pipeline: pose source {} ({} poses)", a.odometry_path, odometry.size());
    // Polls the external flags while the replay sleeps.
    struct StopClock : SteadyReplayClock {
      std::function<bool()> stopped;
      std::atomic<bool>* flag;
      void SleepUntilNs(int64_t t, const std::atomic<bool>*) override {
        constexpr int64_t kSlice = 20'000'000;
        while (!(flag->load() || stopped())) {
          const int64_t now = NowNs();
          if (now >= t) return;
          SteadyReplayClock::SleepUntilNs(std::min(t, now + kSlice), nullptr);
        }
      }
    } clock;
    clock.stopped = stopped;
    clock.flag = &stop_flag;
    FrameReplay replay(source.get(), ropt, &clock);
    const std::function<Submap()> snapshot = [&front] { return front.CurrentSubmap(); };
    Frame frame;
    std::vector<Timestamp> skipped;
    size_t n = 0, next_odometry = 0;
    for (;;) {
      if (stopped()) stop_flag.store(true);
      skipped.clear();
      const bool got = replay.Next(&frame, &skipped, &stop_flag);
      for (Timestamp t : skipped) {
        if (a.max_frames > 0 && n >= static_cast<size_t>(a.max_frames)) break;
        pub.OnSkipped(t);
        ++n;
      }
      if (!got || stopped() || (a.max_frames > 0 && n >= static_cast<size_t>(a.max_frames))) break;
      // The pose source as a robot would deliver it: every pose up to the
      // frame and the next one, so the frame's pose can be interpolated.
      while (next_odometry < odometry.size() &&
             (next_odometry == 0 || odometry[next_odometry - 1].t <= frame.timestamp)) {
        front.AddPosePrior(odometry[next_odometry].t, odometry[next_odometry].T_wc);
        ++next_odometry;
      }
      const FrameRecord rec = front.Track(frame.timestamp, frame.image);
      const FrameTiming& tm = front.timings().back();
      pub.OnFrame(rec, frame.image, tm.total_ms, tm.cpu_ms, front.current_submap_keyframes(), front.FinishedSubmaps(),
                  snapshot);
      ++n;
    }
    const bool by_signal = stopped();
    if (by_signal) spdlog::info("front pipeline: stop requested after {} frames: finishing", n);
    front.Finish();
    if (!pub.Finish(front.FinishedSubmaps(), by_signal)) return 1;
    spdlog::info("front pipeline: done: {} frames, {} skipped by the replay, {} unreadable, {} submaps", n,
                 replay.skipped(), source->skipped(), front.FinishedSubmaps().size());
    return 0;
  } catch (const IpcError& e) {
    spdlog::error("ipc: {}", e.what());
    return 1;
  } catch (const std::exception& e) {
    spdlog::error("front pipeline: {}", e.what());
    return 1;
  }
}

}  // namespace rumi
