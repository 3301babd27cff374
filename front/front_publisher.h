#pragma once
// Realtime-safe glue between the front and the other rumi processes
// (docs/front.md "Running the front in the pipeline", docs/eval.md contract):
//  - feeds the sampler with every frame and ships completed windows to the
//    back (WindowSender, `rumi_<instance>_windows`);
//  - ships front submaps to the manager (SubmapSender, `..._front_submaps`):
//    each finished submap once, and the current one again every
//    resend_interval_s of stream time (the manager replaces it by id);
//  - writes RUNDIR/front_frames.txt and front_samples.txt as frames go, and
//    front.txt and front_stats.json at the end.
//
// Threads: OnFrame/OnSkipped/Finish run on the tracking thread. They only
// feed the sampler, copy what cannot be read from another thread (the
// front's current-submap snapshot and newly finished submaps: Front is not
// thread-safe), and hand work over through a bounded queue (full: dropped
// and counted). Encoding, shared-memory pushes and file writes happen on
// the publisher's own thread. The rings never block (ipc/shm_ring.h).
#include <opencv2/core.hpp>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/camera.h"
#include "common/submap.h"
#include "common/trajectory.h"
#include "common/option_spec.h"
#include "common/process/notify.h"
#include "common/recent_samples.h"
#include "common/window.h"
#include "front/sampler.h"
#include "ipc/channels.h"

namespace rumi {

// YAML section `publisher:`; out_dir, append_files, first_window_id and
// keep_segments are set by the process, not the config.
struct FrontPublisherOptions {
  std::string out_dir;              // RUNDIR; empty: no files are written
  bool append_files = false;        // rumid: a restarted front adds to front_frames.txt
  int64_t first_window_id = 0;      // rumid: ids stay unique across restarts
  bool keep_segments = false;       // rumid: channels stay for a consumer that attaches later
  double resend_interval_s = 2.0;   // stream time between resends of the current submap; 0: never
  // The front drops a submap that loses tracking with <= 4 keyframes
  // (docs/front.md); resending such a one would leave a stale map behind.
  int resend_min_keyframes = 5;
  // End of stream: wait this long for consumers to attach (counted from the
  // channel's creation) and to read everything (counted from the end).
  double wait_for_consumers_s = 30.0;
  double wait_when_stopping_s = 0.5;  // the same after SIGINT/SIGTERM
  // The snapshot runs on the tracking thread: the resend gap grows so that
  // snapshots take at most this share of the stream time.
  double max_snapshot_share = 0.02;
  int queue_capacity = 4;             // windows + resends waiting for the publisher thread
  double flush_interval_s = 0.2;      // file flush / retry period of the publisher thread
  // Hands freed heap back to the system this often (malloc_trim, publisher
  // thread; 0: never). A finished submap's copies and a window's images are
  // tens of MiB; glibc keeps such freed memory for reuse, so the front's RSS
  // showed every past peak (a 28-minute soak: 24 MiB in use, 95 MiB held).
  double heap_trim_interval_s = 30;
  static const OptionSpec<FrontPublisherOptions>& Spec();
  bool Check(std::string* why = nullptr) const;
};

struct FrontPublisherStats {
  uint64_t frames = 0;           // lines in front_frames.txt (tracked + skipped)
  uint64_t skipped_frames = 0;   // replay skipped them (front busy)
  uint64_t windows = 0;          // emitted by the sampler
  uint64_t windows_sent = 0, windows_dropped = 0;  // dropped: queue or ring full, too large
  uint64_t submaps_finished = 0;   // finished submaps handed to the publisher
  uint64_t submap_sends = 0;       // pushes that succeeded (finished + resends)
  uint64_t resends_sent = 0;
  uint64_t submap_drops = 0;       // resends dropped (queue/ring full) + too large
  uint64_t finished_unsent = 0;    // finished submaps still unsent at the end
  uint64_t snapshots = 0;
  double snapshot_ms_median = 0, snapshot_ms_max = 0;  // Front::CurrentSubmap on the tracking thread
  double finished_copy_ms_max = 0;                     // copying a finished submap, tracking thread
  double on_frame_us_median = 0, on_frame_us_p99 = 0, on_frame_us_max = 0;  // OnFrame, tracking thread
  uint64_t heap_trims = 0;
  double heap_trim_ms_max = 0;  // publisher thread
};

class FrontPublisher {
 public:
  // Opens both channels (throws IpcError, e.g. another live producer) and
  // the output files (throws std::runtime_error naming the file).
  FrontPublisher(const FrontPublisherOptions& options, const IpcOptions& ipc, const SamplerOptions& sampler,
                 const PinholeCameraOptions& camera);
  ~FrontPublisher();  // without Finish(): stops the thread, closes the channels at once
  FrontPublisher(const FrontPublisher&) = delete;
  FrontPublisher& operator=(const FrontPublisher&) = delete;

  // Tracking thread, after each Front::Track. `finished` is the front's
  // finished submaps so far (new entries are copied once); `snapshot`
  // returns the front's current submap and is called at most once per
  // resend interval. ms / cpu_ms: the front's time for the frame;
  // submap_keyframes: keyframes in the record's submap (the sampler's S3).
  void OnFrame(const FrameRecord& record, const cv::Mat& image, double ms, double cpu_ms,
               int64_t submap_keyframes, const std::vector<Submap>& finished,
               const std::function<Submap()>& snapshot);
  // A frame the replay skipped: logged as lost, submap -1, skipped = 1.
  void OnSkipped(Timestamp t);
  // Tracking thread, between frames: hands over what the last frame staged
  // when its non-blocking handoff found the publisher thread busy (it waits
  // for the lock; a source that pauses need not hold items until its next
  // frame).
  void Idle() { Handoff(true); }

  // End of stream (after Front::Finish): copies the last finished submaps,
  // flushes the sampler, sends everything, waits for the consumers (bounded;
  // short when `stopping`), writes front.txt and front_stats.json and closes
  // the channels. False (logged) when an output file could not be written.
  bool Finish(const std::vector<Submap>& finished, bool stopping = false);

  FrontPublisherStats stats() const;
  // Finished submaps copied for sending so far (the front may trim them).
  size_t finished_taken() const { return finished_taken_; }
  // Polled by the publisher thread for its status reports (the frame
  // source's state: streaming, reconnecting, ...). Must be thread-safe.
  void SetSourceStatus(std::function<std::string()> status);
  // The source's details (the robot link's statistics) as "link" in the
  // status; null: none.
  void SetSourceDetail(std::function<nlohmann::json()> detail);

 private:
  struct FrameLine {
    Timestamp t;
    TrackingState state;
    int64_t submap_id;
    float ms, cpu_ms;
    bool skipped;
    Timestamp wall;  // when the front was done with it (system clock): loss-to-merge times
  };
  struct SampleLine {
    Timestamp t;
    SampleSet set;
    int64_t window_id;
  };
  struct Job {
    enum Kind { kWindow, kFinished, kResend } kind = kWindow;
    ImageWindow window;
    std::shared_ptr<const Submap> submap;
  };

  void TakeFinished(const std::vector<Submap>& finished);
  // Moves the staged lines and jobs to the publisher thread. The tracking
  // thread only try-locks (block = false): it never waits for the publisher.
  void Handoff(bool block);
  void EnqueueWindow(ImageWindow&& w);
  void Loop();
  void WriteLines(std::vector<FrameLine>* frames, std::vector<SampleLine>* samples);
  void Process(Job& job);
  void RetryFinished();
  void TrimHeap();  // malloc_trim every heap_trim_interval_s
  bool ConsumersDone(int64_t end_ns, bool stopping);
  bool WriteFinalFiles(const std::vector<Submap>& finished);
  void Report();  // publisher thread: status to the supervisor (notify)

  FrontPublisherOptions o_;
  Sampler sampler_;
  std::unique_ptr<WindowSender> windows_;
  std::unique_ptr<SubmapSender> submaps_;
  std::unique_ptr<PoseSender> poses_;  // every frame, from the tracking thread (never waits)
  int64_t opened_ns_ = 0;
  int64_t last_trim_ns_ = 0;  // publisher thread
  Timestamp logged_until_ = 0;  // append mode: front_frames.txt already covers frames up to here
  std::ofstream frames_file_, samples_file_;

  // Tracking-thread state.
  size_t finished_taken_ = 0;
  int64_t count_submap_ = -1, count_frames_ = 0;  // frames the front assigned to the current submap
  int64_t resend_submap_ = -1;
  Timestamp last_resend_t_ = 0;
  double resend_gap_s_ = 0;
  FrontPublisherStats t_stats_;  // counters kept by the tracking thread
  std::vector<FrameLine> staged_lines_;
  std::vector<SampleLine> staged_samples_;
  std::vector<Job> staged_jobs_;
  size_t staged_bounded_ = 0, staged_resends_ = 0;
  bool last_window_ = false;
  RecentSamples on_frame_us_, snapshot_ms_;  // median / p99 over the newest 65,536
  double finished_copy_ms_max_ = 0;
  bool finished_called_ = false;

  // Shared with the publisher thread (mutex_).
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> jobs_;
  // Read by the tracking thread without the lock: a publisher thread
  // preempted while holding mutex_ must not leave it deciding on stale counts.
  std::atomic<size_t> bounded_jobs_{0};  // windows + resends in jobs_
  std::atomic<size_t> resends_queued_{0};  // handed off and not yet sent
  std::vector<FrameLine> frame_lines_;
  std::vector<SampleLine> sample_lines_;
  bool finishing_ = false, stopping_ = false, quit_ = false;
  int64_t end_ns_ = 0;
  FrontPublisherStats p_stats_;  // counters kept by the publisher thread

  // Publisher thread only.
  std::deque<std::shared_ptr<const Submap>> unsent_finished_;
  struct Seen {  // what the written lines say
    uint64_t frames = 0, tracked = 0, skipped = 0, windows = 0;
    TrackingState last_state = TrackingState::kInitializing;
    int64_t last_submap = -1, last_window = -1;
    Timestamp last_t = 0;
  } seen_;
  Notifier notifier_;
  std::mutex source_mutex_;
  std::function<std::string()> source_status_;
  std::function<nlohmann::json()> source_detail_;
  std::thread thread_;
};

// Index of the finished submap with the most tracked frames (front.txt), or
// -1 when there is none.
int LargestFrontSubmap(const std::vector<Submap>& submaps);
// The poses of a submap's tracked frames (front.txt of the largest).
Trajectory TrackedPoses(const Submap& s);

}  // namespace rumi
