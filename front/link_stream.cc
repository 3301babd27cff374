#include "front/link_stream.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <mutex>

#include "ipc/link/link_endpoint.h"
#include "ipc/link/link_frame_image.h"

namespace rumi {
namespace {

class LinkStream : public FrameStream {
 public:
  LinkStream(const LinkOptions& o, const PinholeCameraOptions& camera) : o_(o), camera_(camera) {
    try {
      link_ = std::make_unique<LinkEndpoint>(o);
    } catch (const std::exception& e) {
      throw StreamError(e.what());
    }
    const auto wall = std::chrono::system_clock::now().time_since_epoch();
    const int64_t wall_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wall).count();
    wall_minus_mono_ns_ = wall_ns - LinkNowUs() * 1000;
  }
  const PinholeCamera& camera() const override { return camera_; }
  std::string Describe() const override {
    return "robot link " + o_.bind + " (robot " + std::to_string(o_.robot_id) + ", " +
           std::to_string(camera_.width()) + "x" + std::to_string(camera_.height()) + ")";
  }
  std::string Status() const override {
    if (ended_) return "ended";
    const LinkStats s = link_->stats();
    if (!s.robot_heard)
      return "waiting for the robot on " + o_.bind +
             (s.unauthenticated + s.auth_failures
                  ? " (" + std::to_string(s.unauthenticated + s.auth_failures) + " datagrams refused: no or wrong key)"
                  : std::string());
    if (s.robot_silent_s > o_.silence_s)
      return "robot silent for " + std::to_string(static_cast<int>(s.robot_silent_s)) + " s";
    char b[300];
    std::snprintf(b, sizeof(b), "streaming: %llu frames, %llu dropped, latency p50 %.0f ms%s%s%s%s",
                  static_cast<unsigned long long>(s.frames_delivered),
                  static_cast<unsigned long long>(s.frames.frames_dropped + s.frames_overflow), s.latency_p50_ms,
                  s.robot_halted ? ", robot halted" : "", s.robot_failsafe ? " (fail-safe)" : "",
                  s.insecure ? ", INSECURE link" : "",
                  s.halt_alarm ? ", HALT ALARM: the robot does not do as asked" : "");
    return b;
  }
  nlohmann::json Detail() const override { return link_->stats().ToJson(); }
  std::vector<ImuSample> TakeImu() override {
    std::vector<ImuSample> out;
    for (const LinkImuSample& x : link_->TakeImu()) {
      ImuSample s;
      s.t = x.ground_us * 1000 + wall_minus_mono_ns_;  // the frames' clock
      for (int k = 0; k < 3; ++k) {
        s.gyro[k] = x.gyro[k];
        s.accel[k] = x.accel[k];
      }
      out.push_back(s);
    }
    return out;
  }
  uint64_t unreadable() const override { return unreadable_; }
  bool can_halt() const override { return true; }
  bool SetHalt(bool halt) override {
    link_->SetHalt(halt);
    return link_->HaltAcknowledged();
  }

  bool Next(Frame* frame, std::vector<Timestamp>*, const std::atomic<bool>* stop) override {
    LinkFrameOut f;
    for (;;) {
      if (stop && stop->load()) return false;
      if (!link_->NextFrame(&f, 200, stop)) {
        Idle();
        if (o_.end_after_silence_s > 0) {
          const LinkStats s = link_->stats();
          if (s.robot_heard && s.robot_silent_s >= o_.end_after_silence_s) {
            spdlog::info("source: the robot has been silent for {:.1f} s: the stream ends", s.robot_silent_s);
            ended_ = true;
            return false;
          }
        }
        continue;
      }
      const cv::Mat grey = DecodeLinkFrame(f.frame);
      if (grey.empty()) {
        if (unreadable_++ % 100 == 0)
          spdlog::warn("source: link frame {} does not decode ({} so far)", f.frame.frame_id, unreadable_);
        continue;
      }
      if (grey.cols != camera_.width() || grey.rows != camera_.height()) {
        // Not this calibration's size: ask the robot for it (a robot that was
        // reconfigured by hand), and pass the frame over meanwhile.
        ++unreadable_;
        const int64_t now = LinkNowUs();
        if (now - last_size_request_us_ > 5000000) {
          spdlog::warn("source: the robot sends {}x{} frames, the camera is {}x{}: asking it for {}x{}", grey.cols,
                       grey.rows, camera_.width(), camera_.height(), camera_.width(), camera_.height());
          link_->SendControl(RL_CMD_FRAME_SIZE, camera_.width(), camera_.height());
          last_size_request_us_ = now;
        }
        continue;
      }
      Timestamp t = f.ground_capture_us * 1000 + wall_minus_mono_ns_;
      if (t <= last_t_) t = last_t_ + 1;  // strictly increasing (frame identity)
      last_t_ = t;
      frame->timestamp = t;
      frame->image = grey;
      frame->T_wc_gt.reset();
      frame->path = "link:" + std::to_string(f.frame.frame_id);
      return true;
    }
  }

 private:
  LinkOptions o_;
  PinholeCamera camera_;
  std::unique_ptr<LinkEndpoint> link_;
  int64_t wall_minus_mono_ns_ = 0;
  Timestamp last_t_ = 0;
  int64_t last_size_request_us_ = 0;
  uint64_t unreadable_ = 0;
  std::atomic<bool> ended_{false};
};

}  // namespace

std::unique_ptr<FrameStream> OpenLinkStream(const LinkOptions& o, const PinholeCameraOptions& camera) {
  return std::make_unique<LinkStream>(o, camera);
}

}  // namespace rumi
