#include "front/front_publisher.h"

#include "common/atomic_file.h"

#include <malloc.h>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "common/process/subprocess.h"
#include "common/timestamp.h"
#include "common/trajectory.h"
#include "ipc/channel_watch.h"

namespace rumi {
namespace {

int64_t SteadyNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

double MsBetween(int64_t a, int64_t b) { return static_cast<double>(b - a) * 1e-6; }

// Timestamp of the last line of front_frames.txt (0: none): a restarted
// front appends only what comes after it.
Timestamp LastLoggedFrame(const std::string& path) {
  const std::string tail = FileTail(path, 4096);
  size_t end = tail.find_last_not_of("\n");
  if (end == std::string::npos) return 0;
  const size_t newline = tail.rfind('\n', end);
  const size_t begin = newline == std::string::npos ? 0 : newline + 1;
  const std::string line = tail.substr(begin, end + 1 - begin);
  Timestamp t = 0;
  return ParseSecondsToNs(line.substr(0, line.find(' ')), &t) ? t : 0;
}

std::ofstream OpenOut(const std::string& path, bool append) {
  std::ofstream f(path, append ? std::ios::app : std::ios::trunc);
  if (!f) throw std::runtime_error("cannot write " + path);
  return f;
}

}  // namespace

const OptionSpec<FrontPublisherOptions>& FrontPublisherOptions::Spec() {
  using O = FrontPublisherOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("publisher");
    s->Number("resend_interval_s", &O::resend_interval_s, AtLeast(0.0), AtMost(3600.0),
              "stream time between resends of the current submap to the manager; 0: never");
    s->Number("resend_min_keyframes", &O::resend_min_keyframes, AtLeast(0), AtMost(100000),
              "a submap is resent once it has this many keyframes");
    s->Number("wait_for_consumers_s", &O::wait_for_consumers_s, AtLeast(0.0), AtMost(86400.0),
              "end of stream: wait this long for the back and the manager to read everything");
    s->Number("wait_when_stopping_s", &O::wait_when_stopping_s, AtLeast(0.0), AtMost(3600.0),
              "the same after SIGTERM/SIGINT");
    s->Number("max_snapshot_share", &O::max_snapshot_share, Above(0.0), AtMost(1.0),
              "largest share of the stream time the tracking thread spends copying the current submap");
    s->Number("queue_capacity", &O::queue_capacity, AtLeast(1), AtMost(1000),
              "windows + resends waiting for the publisher thread (full: dropped and counted)");
    s->Number("flush_interval_s", &O::flush_interval_s, Above(0.0), AtMost(60.0),
              "file flush / retry / status period of the publisher thread");
    s->Number("heap_trim_interval_s", &O::heap_trim_interval_s, AtLeast(0.0), AtMost(86400.0),
              "hand freed heap back to the system this often (publisher thread); 0: never");
    return s;
  }();
  return *spec;
}

bool FrontPublisherOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

int LargestFrontSubmap(const std::vector<Submap>& submaps) {
  int best = -1;
  size_t best_n = 0;
  for (size_t i = 0; i < submaps.size(); ++i) {
    const size_t n = TrackedFrames(submaps[i]);
    if (best < 0 || n > best_n) {
      best = static_cast<int>(i);
      best_n = n;
    }
  }
  return best;
}

Trajectory TrackedPoses(const Submap& s) {
  Trajectory t;
  for (const FrameRecord& r : s.frames)
    if (r.state == TrackingState::kTracking) t.push_back({r.timestamp, r.T_wc});
  return t;
}

FrontPublisher::FrontPublisher(const FrontPublisherOptions& options, const IpcOptions& ipc,
                               const SamplerOptions& sampler, const PinholeCameraOptions& camera)
    : o_(options), sampler_(sampler, camera, options.first_window_id) {
  std::string why;
  if (!o_.Check(&why)) throw std::invalid_argument("FrontPublisherOptions: " + why);
  if (!o_.out_dir.empty()) {
    std::filesystem::create_directories(o_.out_dir);
    if (o_.append_files) logged_until_ = LastLoggedFrame(o_.out_dir + "/front_frames.txt");
    frames_file_ = OpenOut(o_.out_dir + "/front_frames.txt", o_.append_files);
    samples_file_ = OpenOut(o_.out_dir + "/front_samples.txt", o_.append_files);
  }
  windows_ = std::make_unique<WindowSender>(ipc);
  submaps_ = std::make_unique<SubmapSender>(ipc, SubmapSource::kFront);
  poses_ = std::make_unique<PoseSender>(ipc);
  if (o_.keep_segments) {
    windows_->ring().KeepSegmentOnClose();
    submaps_->ring().KeepSegmentOnClose();
  }
  opened_ns_ = SteadyNs();
  frame_lines_.reserve(256);
  staged_lines_.reserve(64);
  staged_samples_.reserve(256);
  thread_ = std::thread(&FrontPublisher::Loop, this);
}

FrontPublisher::~FrontPublisher() {
  {
    std::lock_guard<std::mutex> l(mutex_);
    quit_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void FrontPublisher::EnqueueWindow(ImageWindow&& w) {
  ++t_stats_.windows;
  for (const WindowFrame& f : w.frames) staged_samples_.push_back({f.timestamp, f.set, w.id});
  // At the end (Finish) the last window is never refused for room.
  if (!last_window_ && bounded_jobs_ + staged_bounded_ >= static_cast<size_t>(o_.queue_capacity)) {
    ++t_stats_.windows_dropped;
    return;
  }
  staged_jobs_.push_back(Job{Job::kWindow, std::move(w), nullptr});
  ++staged_bounded_;
}

void FrontPublisher::Handoff(bool block) {
  std::unique_lock<std::mutex> l(mutex_, std::defer_lock);
  if (block) {
    l.lock();
  } else if (!l.try_lock()) {
    return;  // the publisher thread holds it: keep the staged items for the next frame
  }
  frame_lines_.insert(frame_lines_.end(), staged_lines_.begin(), staged_lines_.end());
  sample_lines_.insert(sample_lines_.end(), staged_samples_.begin(), staged_samples_.end());
  for (Job& j : staged_jobs_) {
    if (j.kind != Job::kFinished) ++bounded_jobs_;
    if (j.kind == Job::kResend) ++resends_queued_;
    jobs_.push_back(std::move(j));
  }
  l.unlock();
  staged_lines_.clear();
  staged_samples_.clear();
  staged_jobs_.clear();
  staged_bounded_ = 0;
  staged_resends_ = 0;
}

void FrontPublisher::TakeFinished(const std::vector<Submap>& finished) {
  for (; finished_taken_ < finished.size(); ++finished_taken_) {
    const int64_t t0 = SteadyNs();
    auto copy = std::make_shared<const Submap>(finished[finished_taken_]);  // Front is not thread-safe
    finished_copy_ms_max_ = std::max(finished_copy_ms_max_, MsBetween(t0, SteadyNs()));
    ++t_stats_.submaps_finished;
    staged_jobs_.push_back(Job{Job::kFinished, {}, std::move(copy)});
  }
}

void FrontPublisher::OnFrame(const FrameRecord& rec, const cv::Mat& image, double ms, double cpu_ms,
                             int64_t submap_keyframes, const std::vector<Submap>& finished,
                             const std::function<Submap()>& snapshot) {
  const int64_t t0 = SteadyNs();
  poses_->Send({rec.timestamp, rec.state, rec.submap_id, rec.T_wc});  // the live pose (DDS, via the manager)
  if (rec.state != TrackingState::kCoarse) {
    if (rec.submap_id != count_submap_) {
      count_submap_ = rec.submap_id;
      count_frames_ = 0;
    }
    ++count_frames_;
  }
  SamplerFrame sf;
  sf.timestamp = rec.timestamp;
  sf.image = image;
  sf.state = rec.state;
  sf.submap_id = rec.submap_id;
  sf.submap_frames = rec.state == TrackingState::kCoarse ? 0 : count_frames_;
  sf.submap_keyframes = rec.state == TrackingState::kCoarse ? 0 : submap_keyframes;
  ImageWindow w;
  if (sampler_.AddFrame(sf, &w)) EnqueueWindow(std::move(w));
  TakeFinished(finished);
  staged_lines_.push_back({rec.timestamp, rec.state, rec.submap_id, static_cast<float>(ms),
                           static_cast<float>(cpu_ms), false, WallNowNs()});
  ++t_stats_.frames;

  // Resend of the current submap: the snapshot must be taken here (the
  // front's map and frame list change under Track), at most once per gap.
  int64_t snap_ns = 0;
  if (o_.resend_interval_s > 0 && snapshot && rec.state == TrackingState::kTracking) {
    if (rec.submap_id != resend_submap_) {
      resend_submap_ = rec.submap_id;  // first resend one interval after the submap starts tracking
      last_resend_t_ = rec.timestamp;
      resend_gap_s_ = o_.resend_interval_s;
    } else if (NsToSeconds(rec.timestamp - last_resend_t_) >= resend_gap_s_) {
      last_resend_t_ = rec.timestamp;
      if (resends_queued_ + staged_resends_ > 0 || bounded_jobs_ + staged_bounded_ >= static_cast<size_t>(o_.queue_capacity)) {
        ++t_stats_.submap_drops;  // the previous one is still queued: skip this one
      } else {
        const int64_t s0 = SteadyNs();
        auto s = std::make_shared<const Submap>(snapshot());
        snap_ns = SteadyNs() - s0;
        snapshot_ms_.Add(snap_ns * 1e-6);
        // A large map makes the snapshot slow: keep its share of the stream time bounded.
        resend_gap_s_ = std::max(o_.resend_interval_s, snap_ns * 1e-9 / o_.max_snapshot_share);
        if (static_cast<int>(s->keyframes.size()) >= o_.resend_min_keyframes) {
          staged_jobs_.push_back(Job{Job::kResend, {}, std::move(s)});
          ++staged_bounded_;
          ++staged_resends_;
        }
      }
    }
  }
  // No notify: the publisher thread polls every flush_interval_s, so the
  // tracking thread never wakes (and is never preempted by) it.
  Handoff(false);
  // The per-frame figure leaves the periodic snapshot out (reported apart).
  on_frame_us_.Add((SteadyNs() - t0 - snap_ns) * 1e-3);
}

void FrontPublisher::OnSkipped(Timestamp t) {
  if (t <= logged_until_) return;  // an earlier front (before a restart) logged it
  staged_lines_.push_back({t, TrackingState::kLost, -1, 0.f, 0.f, true, WallNowNs()});
  ++t_stats_.frames;
  ++t_stats_.skipped_frames;
  Handoff(false);
}

void FrontPublisher::SetSourceStatus(std::function<std::string()> status) {
  std::lock_guard<std::mutex> l(source_mutex_);
  source_status_ = std::move(status);
}

void FrontPublisher::SetSourceDetail(std::function<nlohmann::json()> detail) {
  std::lock_guard<std::mutex> l(source_mutex_);
  source_detail_ = std::move(detail);
}

void FrontPublisher::Report() {
  nlohmann::json j;
  {
    std::lock_guard<std::mutex> l(mutex_);
    j["windows_sent"] = p_stats_.windows_sent;
    j["windows_dropped"] = p_stats_.windows_dropped;
    j["submap_sends"] = p_stats_.submap_sends;
    j["submap_drops"] = p_stats_.submap_drops;
  }
  {
    std::lock_guard<std::mutex> l(source_mutex_);
    if (source_status_) j["source"] = source_status_();
    if (source_detail_) {
      nlohmann::json d = source_detail_();
      if (!d.is_null()) j["link"] = std::move(d);
    }
  }
  j["process"] = "front";
  j["frames"] = seen_.frames;
  j["tracked"] = seen_.tracked;
  j["skipped"] = seen_.skipped;
  j["state"] = seen_.frames > 0 ? ToString(seen_.last_state) : "starting";
  j["submap"] = seen_.last_submap;
  j["t"] = FormatSeconds(seen_.last_t);
  j["windows"] = seen_.windows;
  notifier_.Heartbeat(j);
}

void FrontPublisher::WriteLines(std::vector<FrameLine>* frames, std::vector<SampleLine>* samples) {
  for (const FrameLine& f : *frames) {
    ++seen_.frames;
    seen_.tracked += f.state == TrackingState::kTracking;
    seen_.skipped += f.skipped;
    seen_.last_state = f.state;
    seen_.last_submap = f.submap_id;
    seen_.last_t = f.t;
  }
  for (const SampleLine& s : *samples) {
    if (s.window_id != seen_.last_window) ++seen_.windows;
    seen_.last_window = s.window_id;
  }
  if (frames_file_.is_open() && !frames->empty()) {
    for (const FrameLine& f : *frames)
      frames_file_ << FormatSeconds(f.t) << ' ' << ToString(f.state) << ' ' << f.submap_id << ' ' << f.ms << ' '
                   << f.cpu_ms << ' ' << (f.skipped ? 1 : 0) << ' ' << FormatSeconds(f.wall) << '\n';
    frames_file_.flush();
  }
  if (samples_file_.is_open() && !samples->empty()) {
    for (const SampleLine& s : *samples)
      samples_file_ << FormatSeconds(s.t) << ' ' << static_cast<int>(s.set) << ' ' << s.window_id << '\n';
    samples_file_.flush();
  }
  frames->clear();
  samples->clear();
}

void FrontPublisher::TrimHeap() {
  if (o_.heap_trim_interval_s <= 0) return;
  const int64_t now = SteadyNs();
  if (last_trim_ns_ == 0) last_trim_ns_ = now;
  if (now - last_trim_ns_ < static_cast<int64_t>(o_.heap_trim_interval_s * 1e9)) return;
  ::malloc_trim(0);
  last_trim_ns_ = SteadyNs();
  std::lock_guard<std::mutex> l(mutex_);
  ++p_stats_.heap_trims;
  p_stats_.heap_trim_ms_max = std::max(p_stats_.heap_trim_ms_max, MsBetween(now, last_trim_ns_));
}

void FrontPublisher::RetryFinished() {
  while (!unsent_finished_.empty()) {
    const PushStatus st = submaps_->Send(*unsent_finished_.front());
    if (st == PushStatus::kDropped) return;  // ring still full: later
    std::lock_guard<std::mutex> l(mutex_);
    if (st == PushStatus::kOk) {
      ++p_stats_.submap_sends;
    } else {
      ++p_stats_.submap_drops;
      spdlog::error("front publisher: finished submap {} does not fit a submap slot (ipc.submap_slot_bytes): lost",
                    unsent_finished_.front()->id);
    }
    unsent_finished_.pop_front();
  }
}

void FrontPublisher::Process(Job& job) {
  if (job.kind == Job::kWindow) {
    const PushStatus st = windows_->Send(job.window);
    std::lock_guard<std::mutex> l(mutex_);
    if (st == PushStatus::kOk) {
      ++p_stats_.windows_sent;
    } else {
      ++p_stats_.windows_dropped;
      spdlog::warn("front publisher: window {} ({} frames) {}", job.window.id, job.window.frames.size(),
                   st == PushStatus::kTooLarge ? "larger than ipc.window_slot_bytes: dropped"
                                               : "dropped: window ring full (back not reading)");
    }
    return;
  }
  if (job.kind == Job::kFinished) {
    unsent_finished_.push_back(std::move(job.submap));  // keeps their order; retried until sent
    RetryFinished();
    return;
  }
  const PushStatus st = submaps_->Send(*job.submap);
  std::lock_guard<std::mutex> l(mutex_);
  --resends_queued_;
  if (st == PushStatus::kOk) {
    ++p_stats_.submap_sends;
    ++p_stats_.resends_sent;
  } else {
    ++p_stats_.submap_drops;  // a newer resend or the finished submap follows
  }
}

bool FrontPublisher::ConsumersDone(int64_t end_ns, bool stopping) {
  const int64_t now = SteadyNs();
  const double wait_s = stopping ? std::min(o_.wait_when_stopping_s, o_.wait_for_consumers_s) : o_.wait_for_consumers_s;
  const int64_t drain_deadline = end_ns + static_cast<int64_t>(wait_s * 1e9);
  const int64_t attach_deadline =
      std::min(drain_deadline, opened_ns_ + static_cast<int64_t>(o_.wait_for_consumers_s * 1e9));
  // Channels left for a later consumer (rumid) need nobody to read them now.
  if (o_.keep_segments && unsent_finished_.empty()) return true;
  const ConsumerProgress w = Consumer(windows_->ring().Stats(), now >= attach_deadline);
  const ConsumerProgress s = Consumer(submaps_->ring().Stats(), now >= attach_deadline);
  const bool done = w != ConsumerProgress::kWaiting &&
                    (s == ConsumerProgress::kGone || (s == ConsumerProgress::kDone && unsent_finished_.empty()));
  if (done || now < drain_deadline) return done;
  spdlog::warn("front publisher: gave up waiting for consumers after {:.1f} s (windows: {}, submaps: {}, {} "
               "finished submaps unsent)",
               wait_s, w == ConsumerProgress::kWaiting ? "unread" : "ok", s == ConsumerProgress::kWaiting ? "unread" : "ok",
               unsent_finished_.size());
  return true;
}

void FrontPublisher::Loop() {
  // Below the tracking and mapping threads: SCHED_BATCH (no wake-up
  // preemption) and nice +10 for this thread only (Linux: per-thread nice).
  sched_param sp{};
  sp.sched_priority = 0;
  pthread_setschedparam(pthread_self(), SCHED_BATCH, &sp);
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
  std::vector<FrameLine> frames;
  std::vector<SampleLine> samples;
  const auto interval = std::chrono::duration<double>(o_.flush_interval_s);
  for (;;) {
    Job job;
    bool have_job = false, finishing = false, stopping = false, quit = false;
    int64_t end_ns = 0;
    {
      std::unique_lock<std::mutex> l(mutex_);
      cv_.wait_for(l, interval, [&] { return !jobs_.empty() || finishing_ || quit_; });
      frames.swap(frame_lines_);
      samples.swap(sample_lines_);
      if (!jobs_.empty()) {
        job = std::move(jobs_.front());
        jobs_.pop_front();
        if (job.kind != Job::kFinished) --bounded_jobs_;
        have_job = true;
      }
      finishing = finishing_;
      stopping = stopping_;
      quit = quit_;
      end_ns = end_ns_;
    }
    WriteLines(&frames, &samples);
    Report();
    TrimHeap();
    if (quit) break;
    if (have_job) {
      Process(job);
      continue;  // drain the queue before anything else
    }
    RetryFinished();
    if (finishing) {
      if (ConsumersDone(end_ns, stopping)) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  std::lock_guard<std::mutex> l(mutex_);
  p_stats_.finished_unsent = unsent_finished_.size();
}

bool FrontPublisher::WriteFinalFiles(const std::vector<Submap>& finished) {
  if (o_.out_dir.empty()) return true;
  bool ok = true;
  const int largest = LargestFrontSubmap(finished);
  const Trajectory traj = largest >= 0 ? TrackedPoses(finished[largest]) : Trajectory();
  const std::string front_txt = o_.out_dir + "/front.txt";
  try {
    WriteTumTrajectory(front_txt, traj);
  } catch (const std::exception& e) {
    spdlog::error("front publisher: {}", e.what());
    ok = false;
  }
  size_t keyframes = 0;
  for (const Submap& s : finished) keyframes += s.keyframes.size();
  const FrontPublisherStats st = stats();
  nlohmann::ordered_json j;
  j["saved_frames"] = keyframes;
  j["submaps"] = finished.size();
  j["largest_submap"] = largest >= 0 ? finished[largest].id : -1;
  j["largest_submap_poses"] = traj.size();
  j["frames"] = st.frames;
  j["skipped_frames"] = st.skipped_frames;
  j["windows"] = st.windows;
  j["windows_sent"] = st.windows_sent;
  j["windows_dropped"] = st.windows_dropped;
  j["submap_sends"] = st.submap_sends;
  j["resends_sent"] = st.resends_sent;
  j["submap_drops"] = st.submap_drops;
  j["finished_unsent"] = st.finished_unsent;
  j["snapshots"] = st.snapshots;
  j["snapshot_ms_median"] = st.snapshot_ms_median;
  j["snapshot_ms_max"] = st.snapshot_ms_max;
  j["finished_copy_ms_max"] = st.finished_copy_ms_max;
  j["publisher_us_median"] = st.on_frame_us_median;
  j["publisher_us_p99"] = st.on_frame_us_p99;
  j["publisher_us_max"] = st.on_frame_us_max;
  j["heap_trims"] = st.heap_trims;
  j["heap_trim_ms_max"] = st.heap_trim_ms_max;
  {
    std::lock_guard<std::mutex> l(source_mutex_);
    if (source_detail_) {
      nlohmann::json d = source_detail_();
      if (!d.is_null()) j["link"] = std::move(d);  // the robot link's final statistics
    }
  }
  std::string why;
  if (!WriteFileAtomically(o_.out_dir + "/front_stats.json", j.dump(2) + "\n", &why)) {
    spdlog::error("front publisher: {}", why);
    ok = false;
  }
  return ok;
}

bool FrontPublisher::Finish(const std::vector<Submap>& finished, bool stopping) {
  if (finished_called_) return true;
  finished_called_ = true;
  TakeFinished(finished);
  last_window_ = true;  // the last window is never refused for room
  ImageWindow w;
  if (sampler_.Flush(&w)) EnqueueWindow(std::move(w));
  Handoff(true);
  {
    std::lock_guard<std::mutex> l(mutex_);
    finishing_ = true;
    stopping_ = stopping;
    end_ns_ = SteadyNs();
  }
  cv_.notify_all();
  thread_.join();
  const FrontPublisherStats st = stats();
  spdlog::info("front publisher: {} frames ({} skipped), windows {} sent / {} dropped, submaps {} finished, {} "
               "sends ({} resends), {} drops, {} unsent; per frame {:.1f} us median, {:.1f} us p99; snapshot "
               "{:.2f} ms median, {:.2f} ms max",
               st.frames, st.skipped_frames, st.windows_sent, st.windows_dropped, st.submaps_finished,
               st.submap_sends, st.resends_sent, st.submap_drops, st.finished_unsent, st.on_frame_us_median,
               st.on_frame_us_p99, st.snapshot_ms_median, st.snapshot_ms_max);
  const bool ok = WriteFinalFiles(finished);
  frames_file_.close();
  samples_file_.close();
  windows_.reset();  // marks the channels closed and removes the segments
  submaps_.reset();
  return ok;
}

FrontPublisherStats FrontPublisher::stats() const {
  FrontPublisherStats s;
  {
    std::lock_guard<std::mutex> l(mutex_);
    s = p_stats_;
  }
  // Tracking-thread figures: read them from the tracking thread (or after Finish).
  s.frames = t_stats_.frames;
  s.skipped_frames = t_stats_.skipped_frames;
  s.windows = t_stats_.windows;
  s.windows_dropped += t_stats_.windows_dropped;
  s.submaps_finished = t_stats_.submaps_finished;
  s.submap_drops += t_stats_.submap_drops;
  s.snapshots = snapshot_ms_.count();
  s.snapshot_ms_median = snapshot_ms_.Percentile(0.5);
  s.snapshot_ms_max = snapshot_ms_.max();
  s.finished_copy_ms_max = finished_copy_ms_max_;
  s.on_frame_us_median = on_frame_us_.Percentile(0.5);
  s.on_frame_us_p99 = on_frame_us_.Percentile(0.99);
  s.on_frame_us_max = on_frame_us_.max();
  return s;
}

}  // namespace rumi
