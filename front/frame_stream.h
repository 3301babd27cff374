#pragma once
// Where the front's frames come from (config section `source:`), as a live
// stream:
//  - kind: dataset  a recorded sequence (tum, euroc, icl, kitti, folder)
//    replayed at its recorded rate (FrameReplay), optionally looped, with the
//    dataset's own timestamps (so it can be evaluated against its ground truth);
//  - kind: capture  anything OpenCV's VideoCapture opens: a V4L2 device
//    (/dev/video0, or an index "0"), a video file, an HTTP MJPEG stream (the
//    ESP32-CAM web server's http://<ip>:81/stream). Frames get ground-station
//    capture timestamps: the monotonic clock at the grab, mapped to wall time
//    once at start (so an NTP step never makes time run backwards). A device
//    or stream that fails or stalls (no frame for stall_timeout_s) is
//    reopened with a backoff; a file ends the stream at its end (or starts
//    again with loop).
//  - kind: link  the robot link (docs/robot_link.md): frames from the robot's
//    ESP32-CAM over UDP (ipc/link), JPEG decoded here, capture timestamps on
//    the ground clock through the link's clock sync; the stream halts and
//    resumes the robot for the front's hierarchical mode.
// A frame whose size is not the camera's is refused: StreamError (bad input).
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/camera.h"
#include "common/dataset.h"
#include "common/imu.h"
#include "common/option_spec.h"
#include "ipc/link/link_options.h"

namespace rumi {

struct SourceOptions {
  std::string kind = "dataset";  // dataset | capture | link
  std::string dataset = "tum";   // dataset: tum|euroc|icl|kitti|folder
  // dataset: its folder. capture: /dev/videoN, a device index, a video file
  // or a URL (http://host:81/stream, rtsp://...).
  std::string path;
  double rate = 1.0;             // dataset: x recorded speed; 0: as fast as possible
  bool loop = false;             // dataset / video file: start again at the end
  std::string odometry;          // dataset: TUM file of the robot's pose source (optional)
  std::string imu;               // dataset: IMU file (EuRoC imu0 columns; optional)
  // dataset: its calibration. "": the config's camera: section when it has
  // one, else the dataset's own; "dataset": the dataset's own (TUM fr1-3,
  // EuRoC sensor.yaml, KITTI calib.txt, ...); a path: that YAML's camera:
  // section (`rumi synth` writes camera.yaml beside its images).
  std::string calibration;
  double fps = 0;                // capture of a video file: pace at this rate; 0: the file's own
  double stall_timeout_s = 3.0;  // capture: no frame for this long = stalled, reopen
  double reconnect_initial_s = 0.5;  // capture: first wait before reopening; doubles up to the max
  double reconnect_max_s = 10.0;
  LinkOptions link;              // link: the robot link's ground end
  static const OptionSpec<SourceOptions>& Spec();
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
};

// The stream cannot go on, and restarting will not help (a frame of the
// wrong size, a file that does not exist): the front exits kExitBadInput.
class StreamError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class FrameStream {
 public:
  virtual ~FrameStream() = default;
  virtual const PinholeCamera& camera() const = 0;
  // Next frame (8-bit grey, the camera's size). Frames the stream passed
  // over because the front was late go to *skipped. False at the end of the
  // stream or once *stop is set. Throws StreamError.
  virtual bool Next(Frame* frame, std::vector<Timestamp>* skipped, const std::atomic<bool>* stop) = 0;
  virtual std::string Describe() const = 0;
  // "streaming", "reconnecting: ...", "ended" (for the status); any thread.
  virtual std::string Status() const = 0;
  virtual uint64_t unreadable() const = 0;  // frames that could not be decoded
  // Added to the dataset's listed timestamps (a looped dataset); 0 otherwise.
  virtual Timestamp timestamp_offset() const { return 0; }
  // IMU samples the source received since the last call (a robot link's),
  // on the frames' clock. Next's thread.
  virtual std::vector<ImuSample> TakeImu() { return {}; }
  // Details for the status (the link's statistics); null when none. Any thread.
  virtual nlohmann::json Detail() const { return nullptr; }
  // A source that can stop the robot (the link): halt while the front wants
  // it (hierarchical mode). True when the robot confirmed what was asked.
  virtual bool SetHalt(bool /*halt*/) { return true; }
  virtual bool can_halt() const { return false; }
  // Called on Next's thread about every 200 ms while Next waits for a frame
  // that does not come (a live source): the caller's upkeep that must not
  // wait for the next frame (a halted robot's resume).
  void SetIdle(std::function<void()> idle) { idle_ = std::move(idle); }

 protected:
  void Idle() const {
    if (idle_) idle_();
  }

 private:
  std::function<void()> idle_;
};

struct StreamOpenOptions {
  SourceOptions source;
  // dataset: the rumi config (its camera: section, see source.calibration).
  std::string config_path;
  // capture, link: the camera (required: they have no calibration of their own).
  const PinholeCameraOptions* camera = nullptr;
  // Clock time (steady, ns) the session started: a dataset's first frame is
  // due then; a video file is sought to now - start on open (a restarted
  // front goes on where the stream is). 0: now.
  int64_t start_ns = 0;
};

// Throws StreamError when the source cannot be used at all (no such dataset,
// no such file, no camera for a capture). A device or URL that is not there
// yet is not an error: the stream keeps trying.
std::unique_ptr<FrameStream> OpenFrameStream(const StreamOpenOptions& options);

}  // namespace rumi
