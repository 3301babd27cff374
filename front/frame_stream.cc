#include "front/frame_stream.h"

#include <spdlog/spdlog.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <thread>

#include "front/frame_replay.h"
#include "front/link_stream.h"

namespace rumi {

const OptionSpec<SourceOptions>& SourceOptions::Spec() {
  using O = SourceOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("source");
    s->Choice("kind", &O::kind, {"dataset", "capture", "link"},
              "dataset: a recorded sequence replayed live; capture: a camera, video file or stream; "
              "link: the robot link (UDP)");
    s->Choice("dataset", &O::dataset, {"tum", "euroc", "icl", "kitti", "folder"}, "dataset layout");
    s->Text("path", &O::path, "dataset folder; or /dev/videoN, a device index, a video file, an http:// stream");
    s->Number("rate", &O::rate, AtLeast(0.0), AtMost(1000.0), "dataset: x recorded speed; 0: as fast as possible");
    s->Flag("loop", &O::loop, "dataset or video file: start again at the end (timestamps keep increasing)");
    s->Text("odometry", &O::odometry, "dataset: TUM file of the robot's pose source (optional)");
    s->Text("imu", &O::imu, "dataset: IMU file, EuRoC imu0 columns (`rumi synth` writes imu.csv; optional)");
    s->Text("calibration", &O::calibration,
            "dataset: '' the config's camera: (else the dataset's own), 'dataset' its own, or a YAML file's camera:");
    s->Number("fps", &O::fps, AtLeast(0.0), AtMost(1000.0), "capture of a video file: pace at this rate; 0: its own");
    s->Number("stall_timeout_s", &O::stall_timeout_s, Above(0.0), AtMost(3600.0),
              "capture: no frame for this long = stalled, reopen");
    s->Number("reconnect_initial_s", &O::reconnect_initial_s, Above(0.0), AtMost(3600.0),
              "capture: first wait before reopening (doubles)");
    s->Number("reconnect_max_s", &O::reconnect_max_s, Above(0.0), AtMost(3600.0), "capture: longest wait");
    s->Section("link", &O::link, LinkOptions::Spec());
    s->Rule("reconnect_max_s must be >= reconnect_initial_s",
            [](const O& o) { return o.reconnect_max_s >= o.reconnect_initial_s; });
    s->Rule("kind link: set link.key_file (a key from `rumi link keygen`) or, for an unauthenticated lab link, "
            "link.insecure: true",
            [](const O& o) { return o.kind != "link" || o.link.Keyed(); });
    return s;
  }();
  return *spec;
}

namespace {

using Clock = std::chrono::steady_clock;

int64_t SteadyNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

// ---- a dataset, replayed -----------------------------------------------------
class DatasetStream : public FrameStream {
 public:
  explicit DatasetStream(const StreamOpenOptions& o) {
    DatasetOptions d;
    if (!ParseDatasetKind(o.source.dataset, &d.kind)) throw StreamError("unknown dataset kind '" + o.source.dataset + "'");
    d.path = o.source.path;
    const std::string& cal = o.source.calibration;
    d.config_path = cal.empty() ? o.config_path : cal == "dataset" ? std::string() : cal;
    if (!cal.empty() && cal != "dataset" && !std::filesystem::is_regular_file(cal))
      throw StreamError("source.calibration: no such file: " + cal);
    std::string why;
    if (d.path.empty()) throw StreamError("source.path is empty: which dataset?");
    if (!d.Check(&why)) throw StreamError("dataset options: " + why);
    try {
      source_ = OpenDataset(d);
    } catch (const std::exception& e) {
      throw StreamError(e.what());
    }
    FrameReplayOptions r;
    r.max = o.source.rate <= 0;
    r.rate = r.max ? 1.0 : o.source.rate;
    r.loop = o.source.loop;
    r.start_ns = o.start_ns;
    replay_ = std::make_unique<FrameReplay>(source_.get(), r);
    describe_ = o.source.dataset + " dataset " + o.source.path + " (" + std::to_string(source_->size()) +
                " frames, rate " + (r.max ? std::string("max") : std::to_string(r.rate)) +
                (r.loop ? ", looped" : "") + ")";
  }
  const PinholeCamera& camera() const override { return source_->camera(); }
  bool Next(Frame* frame, std::vector<Timestamp>* skipped, const std::atomic<bool>* stop) override {
    const bool got = replay_->Next(frame, skipped, stop);
    ended_ = !got;
    loops_ = replay_->loops();
    return got;
  }
  std::string Describe() const override { return describe_; }
  std::string Status() const override {  // any thread
    const int loops = loops_;
    return ended_ ? "ended" : loops > 0 ? "replaying, loop " + std::to_string(loops + 1) : "replaying";
  }
  uint64_t unreadable() const override { return source_->skipped(); }
  Timestamp timestamp_offset() const override { return replay_->offset(); }

 private:
  std::unique_ptr<FrameSource> source_;
  std::unique_ptr<FrameReplay> replay_;
  std::string describe_;
  std::atomic<bool> ended_{false};
  std::atomic<int> loops_{0};
};

// ---- OpenCV VideoCapture: device, file, stream ---------------------------------
class CaptureStream : public FrameStream {
 public:
  CaptureStream(const SourceOptions& o, const PinholeCameraOptions& camera, int64_t start_ns)
      : o_(o), camera_(camera), start_ns_(start_ns) {
    const std::string& p = o_.path;
    is_device_ = p.rfind("/dev/", 0) == 0 || (!p.empty() && std::all_of(p.begin(), p.end(), ::isdigit));
    is_url_ = p.find("://") != std::string::npos;
    is_file_ = !is_device_ && !is_url_;
    if (p.empty()) throw StreamError("source.path is empty: which camera, file or stream?");
    if (is_file_ && !std::filesystem::exists(p)) throw StreamError("source.path: no such video file: " + p);
    // Wall time of the monotonic clock's zero, taken once.
    const auto wall = std::chrono::system_clock::now().time_since_epoch();
    wall_minus_mono_ns_ = std::chrono::duration_cast<std::chrono::nanoseconds>(wall).count() - SteadyNowNs();
    SetStatus("opening");
  }
  const PinholeCamera& camera() const override { return camera_; }
  std::string Describe() const override {
    return std::string(is_device_ ? "camera " : is_url_ ? "stream " : "video file ") + o_.path + " (" +
           std::to_string(camera_.width()) + "x" + std::to_string(camera_.height()) + ")";
  }
  std::string Status() const override {
    std::lock_guard<std::mutex> l(status_mutex_);
    return status_;
  }
  uint64_t unreadable() const override { return unreadable_; }

  bool Next(Frame* frame, std::vector<Timestamp>*, const std::atomic<bool>* stop) override {
    for (;;) {
      if (stop && stop->load()) return false;
      if (!cap_.isOpened() && !Open(stop)) return false;
      // A video file plays at its frame rate, as a camera would deliver it.
      if (is_file_ && frame_interval_ns_ > 0 && next_due_ns_ > 0) SleepUntil(next_due_ns_, stop);
      cv::Mat img;
      const bool ok = cap_.read(img);
      const int64_t mono = SteadyNowNs();
      if (!ok || img.empty()) {
        if (is_file_ && !o_.loop) {
          SetStatus("ended");
          spdlog::info("source: end of {}", o_.path);
          return false;
        }
        spdlog::warn("source: {} gave no frame{}; reopening", o_.path, is_file_ ? " (end of file, looping)" : "");
        cap_.release();
        if (!is_file_) ScheduleReconnect();
        continue;
      }
      next_due_ns_ = (next_due_ns_ > 0 ? next_due_ns_ : mono) + frame_interval_ns_;
      cv::Mat grey;
      if (img.channels() == 3) cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
      else if (img.channels() == 4) cv::cvtColor(img, grey, cv::COLOR_BGRA2GRAY);
      else grey = img;
      if (grey.depth() != CV_8U) {
        ++unreadable_;
        continue;
      }
      if (grey.cols != camera_.width() || grey.rows != camera_.height()) {
        throw StreamError(o_.path + " delivers " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) +
                          " frames but the camera is " + std::to_string(camera_.width()) + "x" +
                          std::to_string(camera_.height()) + ": use the calibration of this image size");
      }
      // Ground-station capture time; strictly increasing (frame identity).
      Timestamp t = mono + wall_minus_mono_ns_;
      if (t <= last_t_) t = last_t_ + 1;
      last_t_ = t;
      frame->timestamp = t;
      frame->image = grey;
      frame->T_wc_gt.reset();
      frame->path = o_.path;
      reconnect_wait_s_ = 0;
      return true;
    }
  }

 private:
  void SetStatus(const std::string& s) {
    std::lock_guard<std::mutex> l(status_mutex_);
    status_ = s;
  }
  void SleepUntil(int64_t t_ns, const std::atomic<bool>* stop) {
    while (!(stop && stop->load())) {
      const int64_t left = t_ns - SteadyNowNs();
      if (left <= 0) return;
      std::this_thread::sleep_for(std::chrono::nanoseconds(std::min<int64_t>(left, 50'000'000)));
    }
  }
  void ScheduleReconnect() {
    reconnect_wait_s_ = reconnect_wait_s_ <= 0 ? o_.reconnect_initial_s : std::min(o_.reconnect_max_s, 2 * reconnect_wait_s_);
    reopen_at_ns_ = SteadyNowNs() + static_cast<int64_t>(reconnect_wait_s_ * 1e9);
  }
  bool Open(const std::atomic<bool>* stop) {
    for (int attempt = 1;; ++attempt) {
      if (reopen_at_ns_ > 0) {
        SetStatus("reconnecting: next try in " + std::to_string(static_cast<int>(std::ceil(reconnect_wait_s_))) +
                  " s (attempt " + std::to_string(attempt) + ")");
        SleepUntil(reopen_at_ns_, stop);
      }
      if (stop && stop->load()) return false;
      const int timeout_ms = static_cast<int>(o_.stall_timeout_s * 1000);
      const std::vector<int> params = {cv::CAP_PROP_OPEN_TIMEOUT_MSEC, timeout_ms, cv::CAP_PROP_READ_TIMEOUT_MSEC,
                                       timeout_ms};
      bool ok = false;
      try {
        if (is_device_ && std::all_of(o_.path.begin(), o_.path.end(), ::isdigit)) {
          ok = cap_.open(std::stoi(o_.path), cv::CAP_ANY);
        } else {
          // Files and streams through FFmpeg (Debian's OpenCV has it): trying
          // every backend on a URL fills the log with their refusals.
          ok = cap_.open(o_.path, is_device_ ? cv::CAP_V4L2 : cv::CAP_FFMPEG, params);
        }
      } catch (const cv::Exception& e) {
        spdlog::warn("source: opening {}: {}", o_.path, e.what());
        ok = false;
      }
      if (ok && cap_.isOpened()) {
        const double file_fps = cap_.get(cv::CAP_PROP_FPS);
        const double fps = o_.fps > 0 ? o_.fps : file_fps;
        frame_interval_ns_ = is_file_ && fps > 0 && std::isfinite(fps) ? static_cast<int64_t>(1e9 / fps) : 0;
        next_due_ns_ = 0;
        // A restarted front on a video file goes on where the file is now,
        // not at its start (rumid hands every front the session's start).
        if (is_file_ && start_ns_ > 0 && !seeked_) {
          const double elapsed_ms = static_cast<double>(SteadyNowNs() - start_ns_) * 1e-6;
          if (elapsed_ms > 0) cap_.set(cv::CAP_PROP_POS_MSEC, elapsed_ms);
          seeked_ = true;
        }
        SetStatus("streaming");
        spdlog::info("source: {} open ({})", Describe(), cap_.getBackendName());
        reopen_at_ns_ = 0;
        return true;
      }
      cap_.release();
      if (is_file_) throw StreamError("source: cannot open the video file " + o_.path);
      ScheduleReconnect();
      spdlog::warn("source: cannot open {}; trying again in {:.1f} s", o_.path, reconnect_wait_s_);
    }
  }

  SourceOptions o_;
  PinholeCamera camera_;
  int64_t start_ns_ = 0;
  bool seeked_ = false;
  cv::VideoCapture cap_;
  bool is_device_ = false, is_url_ = false, is_file_ = false;
  int64_t wall_minus_mono_ns_ = 0;
  Timestamp last_t_ = 0;
  int64_t frame_interval_ns_ = 0, next_due_ns_ = 0, reopen_at_ns_ = 0;
  double reconnect_wait_s_ = 0;
  uint64_t unreadable_ = 0;
  mutable std::mutex status_mutex_;
  std::string status_;
};

}  // namespace

std::unique_ptr<FrameStream> OpenFrameStream(const StreamOpenOptions& o) {
  std::string why;
  if (!o.source.Check(&why)) throw StreamError("source: " + why);
  if (o.source.kind == "dataset") return std::make_unique<DatasetStream>(o);
  if (!o.camera)
    throw StreamError("source.kind " + o.source.kind + " needs a camera: section (its calibration) in the config");
  if (o.source.kind == "link") return OpenLinkStream(o.source.link, *o.camera);
  return std::make_unique<CaptureStream>(o.source, *o.camera, o.start_ns);
}

}  // namespace rumi
