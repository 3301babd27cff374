#include "back/back_run.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "back/back_submap_builder.h"
#include "back/colmap_workspace.h"
#include "back/window_queue.h"
#include "common/atomic_file.h"
#include "common/logging.h"
#include "common/process/exit_codes.h"
#include "common/process/notify.h"
#include "common/timestamp.h"
#include "ipc/channel_watch.h"
#include "ipc/window_codec.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Back submap ids under rumid: window id x this + model index.
constexpr int64_t kSubmapsPerWindow = 100;

// What back_stats.json reports per window. Written by the worker thread only.
struct WindowRecord {
  int64_t window_id = -1;
  BackStatus status = BackStatus::kInvalidWindow;
  std::string message;
  int frames = 0, registered = 0;
  int attempt = 1;                           // 2: retried after the back died on it
  std::vector<int64_t> joined;               // windows merged into it while it waited
  Timestamp started = 0, finished = 0;       // system clock: the build
  bool retried = false, retry_kept = false;  // lower SIFT threshold tried / kept
  int matched_pairs = 0;                     // image pairs per attempt
  bool filled = false, fill_kept = false;    // the remaining pairs matched / kept
  std::vector<int64_t> submap_ids;
  std::vector<std::vector<std::string>> submap_stamps;  // per sent submap: its keyframes' timestamps
  BackStepTimes times;
  BackResult::Remote remote;                 // worker "" = built here
};

// Shared between the receiver thread (status, liveness) and the worker.
struct Shared {
  std::mutex mutex;
  uint64_t received = 0, decode_errors = 0, spool_dropped = 0;
  ProducerEnd producer_end = ProducerEnd::kRunning;
  bool receiver_done = false;
  // The window being built: id, frames, COLMAP stage, since when.
  int64_t building = -1;
  int building_frames = 0;
  std::string stage;
  Clock::time_point building_since{};
  uint64_t built = 0, failed = 0;
  std::atomic<bool> abort{false};  // stop requested or the manager is gone: cancel COLMAP
  std::atomic<bool> peer_gone{false};
};

struct Counters {
  uint64_t submaps_sent = 0, submaps_dropped = 0;
  double seconds = 0.0;  // wall seconds inside BackSubmapBuilder::Build
  std::vector<WindowRecord> windows;
};

nlohmann::ordered_json StatsJson(const Counters& c, Shared& sh, const WindowQueue& queue, bool stopped) {
  const uint64_t dropped = queue.dropped();
  using json = nlohmann::ordered_json;
  uint64_t done = 0, failed = 0, cancelled = 0;
  json per = json::array();
  for (const WindowRecord& w : c.windows) {
    if (w.status == BackStatus::kOk) ++done;
    else if (w.status == BackStatus::kCancelled) ++cancelled;
    else ++failed;
    const BackStepTimes& t = w.times;
    per.push_back({{"window_id", w.window_id},
                   {"status", ToString(w.status)},
                   {"message", w.message},
                   {"frames", w.frames},
                   {"registered", w.registered},
                   {"attempt", w.attempt},
                   {"joined_windows", w.joined},
                   {"started_wall_s", NsToSeconds(w.started)},
                   {"finished_wall_s", NsToSeconds(w.finished)},
                   {"retried", w.retried},
                   {"retry_kept", w.retry_kept},
                   {"matched_pairs", w.matched_pairs},
                   {"filled", w.filled},
                   {"fill_kept", w.fill_kept},
                   {"built_by", w.remote.worker.empty() ? "local" : w.remote.worker},
                   {"remote",
                    {{"bytes_out", w.remote.bytes_out},
                     {"bytes_in", w.remote.bytes_in},
                     {"claim_wait_s", w.remote.claim_wait_s},
                     {"offers", w.remote.offers}}},
                   {"submaps", w.submap_ids},
                   {"submap_timestamps", w.submap_stamps},
                   {"seconds",
                    {{"undistort_write", t.undistort_write_s},
                     {"feature_extraction", t.feature_extraction_s},
                     {"matching", t.matching_s},
                     {"mapping", t.mapping_s},
                     {"read_convert", t.read_convert_s},
                     {"total", t.total_s}}},
                   {"cpu_seconds",
                    {{"feature_extraction", t.feature_extraction_cpu_s},
                     {"matching", t.matching_cpu_s},
                     {"mapping", t.mapping_cpu_s}}}});
  }
  json history = json::array();  // [wall_s, waiting windows] after each change
  for (const auto& [t, n] : queue.History()) history.push_back({NsToSeconds(t), n});
  std::lock_guard<std::mutex> l(sh.mutex);
  return {{"windows", c.windows.size()},  // processed (docs/eval.md contract)
          {"seconds", c.seconds},
          {"windows_received", sh.received},
          {"windows_done", done},
          {"windows_failed", failed},
          {"windows_cancelled", cancelled},
          {"windows_dropped", dropped + sh.spool_dropped},
          {"windows_joined", queue.merged()},
          {"windows_undecodable", sh.decode_errors},
          {"submaps_sent", c.submaps_sent},
          {"submaps_dropped", c.submaps_dropped},
          {"producer", ToString(sh.producer_end)},
          {"stopped_by_signal", stopped},
          {"per_window", per},
          {"queue_history", history}};
}

bool WriteStats(const std::string& work_dir, const nlohmann::ordered_json& j) {
  std::string why;
  if (WriteFileAtomically((fs::path(work_dir) / "back_stats.json").string(), j.dump(2) + "\n", &why)) return true;
  spdlog::error("back: {}", why);
  return false;
}

// ---- the spool (rumid): windows on disk until built ----------------------------
class Spool {
 public:
  explicit Spool(std::string dir) : dir_(std::move(dir)) {}
  bool enabled() const { return !dir_.empty(); }
  std::string WindowPath(int64_t id) const { return (fs::path(dir_) / (std::to_string(id) + ".rwin")).string(); }
  std::string AttemptPath(int64_t id) const { return (fs::path(dir_) / (std::to_string(id) + ".attempt")).string(); }
  bool Put(const ImageWindow& w, std::string* why) const {
    return !enabled() || WriteFileAtomically(WindowPath(w.id), EncodeWindow(w), why);
  }
  // Marks the start of a build; returns the attempt number (1, 2, ...).
  int Start(int64_t id) const {
    if (!enabled()) return 1;
    const int attempt = Attempts(id) + 1;
    SetAttempts(id, attempt);
    return attempt;
  }
  // A build that ended without dying (cancelled by a stop, submaps not
  // delivered) does not count: the window stays for the next start.
  void Keep(int64_t id, int attempt) const {
    if (enabled()) SetAttempts(id, attempt - 1);
  }
  bool Has(int64_t id) const { return enabled() && std::filesystem::exists(WindowPath(id)); }
  void Remove(int64_t id) const {
    if (!enabled()) return;
    std::error_code ec;
    fs::remove(WindowPath(id), ec);
    fs::remove(AttemptPath(id), ec);
  }
  void SetAttempts(int64_t id, int n) const {
    std::string why;
    if (!WriteFileAtomically(AttemptPath(id), std::to_string(n) + "\n", &why)) spdlog::warn("back: {}", why);
  }
  int Attempts(int64_t id) const {
    std::ifstream in(AttemptPath(id));
    int n = 0;
    return in >> n ? n : 0;
  }
  // The windows left by an earlier rumi-back, oldest first.
  std::vector<ImageWindow> Load() const {
    std::vector<ImageWindow> out;
    if (!enabled()) return out;
    std::error_code ec;
    fs::create_directories(dir_, ec);
    std::vector<int64_t> ids;
    for (const auto& e : fs::directory_iterator(dir_, ec)) {
      if (e.path().extension() != ".rwin") continue;
      try {
        ids.push_back(std::stoll(e.path().stem().string()));
      } catch (const std::exception&) {
        spdlog::warn("back: {} in the spool is not a window file; ignored", e.path().string());
      }
    }
    std::sort(ids.begin(), ids.end());
    for (int64_t id : ids) {
      std::vector<uint8_t> bytes;
      std::string why;
      ImageWindow w;
      if (!ReadFileBytes(WindowPath(id), &bytes, &why) || !DecodeWindow(bytes.data(), bytes.size(), &w, false, &why)) {
        spdlog::error("back: spooled window {} does not load ({}); dropped", id, why);
        Remove(id);
        continue;
      }
      out.push_back(std::move(w));
    }
    return out;
  }

 private:
  std::string dir_;
};

// Queues a window (spooled already under its id). A window that joins a
// waiting one keeps its spool file until that one is built: after a crash
// both load and join again.
void Enqueue(ImageWindow w, WindowQueue* queue, const Spool& spool, const BackOptions& o, bool retry = false) {
  const int64_t id = w.id;
  const size_t frames = w.frames.size();
  const WindowQueue::PushResult r = queue->Push(std::move(w), /*sealed=*/retry);
  for (int64_t d : r.dropped) spool.Remove(d);
  if (!r.dropped.empty())
    spdlog::warn("back: queue full ({} windows): dropped the oldest waiting window{} ({} dropped so far)",
                 o.max_queue_windows, r.dropped.size() > 1 ? " and the windows it had joined" : "", queue->dropped());
  if (r.merged_into >= 0) {
    spdlog::info("back: window {} ({} frames) joins waiting window {} (it starts within {} s of its end), {} waiting",
                 id, frames, r.merged_into, o.merge_gap_s, queue->size());
  } else {
    spdlog::info("back: window {} ({} frames) queued, {} waiting", id, frames, queue->size());
  }
}

// Whether the window stream is over: its producer closed its channel (and,
// under rumid, the source ended), died (`rumi eval run` only), or never came.
bool StreamOver(const BackRunOptions& o, ProducerEnd end) {
  const bool finished = !o.finish || o.finish->load();
  return ((end == ProducerEnd::kClosed || end == ProducerEnd::kNeverAppeared) && finished) ||
         (end == ProducerEnd::kDied && o.producer_death_ends);
}

// Pulls windows off the ring into the queue as fast as they come, so the ring
// never fills while COLMAP runs (the queue drops its oldest window instead),
// watches the producer and the manager, and reports the status.
void ReceiveLoop(const BackRunOptions& o, WindowReceiver* rx, SubmapSender* tx, WindowQueue* queue,
                 const Spool* spool, Shared* sh, const std::atomic<bool>* stop) {
  ProducerWatch watch("window", o.back.wait_for_producer_s);
  auto last_peer_check = Clock::now();
  Clock::time_point peer_missing_since{};
  for (;;) {
    if ((stop && stop->load()) || sh->abort.load()) break;
    const uint64_t closed_before = rx->ring().closed_segments();
    ImageWindow w;
    const PopStatus st = rx->Receive(&w, 0.05, /*hold=*/spool->enabled());
    watch.Update(rx->ring(), st, closed_before);
    {
      std::lock_guard<std::mutex> l(sh->mutex);
      sh->decode_errors = rx->decode_errors();
      sh->producer_end = watch.end();
    }
    if (st == PopStatus::kOk) {
      if (spool->Has(w.id)) {  // spooled, then killed before the slot was let go: it is queued already
        rx->Release();
        spdlog::info("back: window {} is in the spool already; not queued twice", w.id);
        continue;
      }
      std::string why;
      if (!spool->Put(w, &why)) spdlog::error("back: cannot spool window {}: {}", w.id, why);
      if (spool->enabled()) rx->Release();  // on disk now
      {
        std::lock_guard<std::mutex> l(sh->mutex);
        ++sh->received;
      }
      Enqueue(std::move(w), queue, *spool, o.back);
      continue;
    }
    if (StreamOver(o, watch.end())) break;
    // Under rumid, the source ended (the front exited for good) and no
    // window channel is left: a back restarted after the front closed and
    // removed a drained channel would otherwise wait for it forever.
    if (o.finish && o.finish->load() && st == PopStatus::kNotConnected) {
      spdlog::info("back: the source ended and no window channel is left: nothing more will come");
      std::lock_guard<std::mutex> l(sh->mutex);
      sh->producer_end = ProducerEnd::kClosed;
      break;
    }
    if (st != PopStatus::kEmpty) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    // The manager (consumer of our submaps) gone and not back: nobody to work for.
    if (std::chrono::duration<double>(Clock::now() - last_peer_check).count() > 0.5) {
      last_peer_check = Clock::now();
      const RingStats rs = tx->ring().Stats();
      const bool missing = rs.consumer_generation > 0 && !rs.consumer_alive;
      if (!missing) {
        peer_missing_since = {};
      } else if (peer_missing_since == Clock::time_point{}) {
        peer_missing_since = Clock::now();
        spdlog::warn("back: the manager (pid {}) is gone; waiting up to {} s for it to come back", rs.consumer_pid,
                     o.back.peer_timeout_s);
      } else if (std::chrono::duration<double>(Clock::now() - peer_missing_since).count() > o.back.peer_timeout_s) {
        spdlog::error("back: the manager has been gone for {} s: stopping", o.back.peer_timeout_s);
        sh->peer_gone.store(true);
        sh->abort.store(true);
        break;
      }
    }
  }
  {
    std::lock_guard<std::mutex> l(sh->mutex);
    sh->receiver_done = true;
  }
  queue->Close();
  // The source may have ended while the worker still drains the queue: a
  // stop then must still cancel COLMAP (it used to go unheard until rumid's
  // SIGKILL, and the window counted a failed attempt). The worker sets abort
  // when it is done.
  while (!sh->abort.load()) {
    if (stop && stop->load()) sh->abort.store(true);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

// The status for a supervisor (notify), every half second until *done.
void ReportLoop(Shared* sh, const WindowQueue* queue, const std::atomic<bool>* done) {
  Notifier notifier;
  while (!done->load()) {
    nlohmann::json j;
    {
      std::lock_guard<std::mutex> l(sh->mutex);
      j = {{"process", "back"},     {"received", sh->received}, {"queue", queue->size()},
           {"built", sh->built},    {"failed", sh->failed},     {"dropped", queue->dropped() + sh->spool_dropped},
           {"joined", queue->merged()}, {"producer", ToString(sh->producer_end)}};
      if (sh->building >= 0) {
        j["building"] = {{"window", sh->building},
                         {"frames", sh->building_frames},
                         {"stage", sh->stage},
                         {"elapsed_s", std::chrono::duration<double>(Clock::now() - sh->building_since).count()}};
      }
    }
    notifier.Heartbeat(j);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

// The back is not realtime: a full submap ring is retried (the manager reads
// it soon) rather than dropped, up to wait_s.
PushStatus SendWithRetry(SubmapSender* tx, const Submap& s, double wait_s, const std::atomic<bool>* abort) {
  const auto start = Clock::now();
  bool warned = false;
  for (;;) {
    const PushStatus st = tx->Send(s);
    if (st != PushStatus::kDropped) return st;
    if (abort->load() || SecondsSince(start) > wait_s) return st;
    if (!warned) {
      spdlog::warn("back: submap ring full; retrying submap {} for up to {} s", s.id, wait_s);
      warned = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

}  // namespace

int RunBack(const BackRunOptions& o, const std::atomic<bool>* stop) {
  std::error_code ec;
  fs::create_directories(o.work_dir, ec);
  if (ec) {
    spdlog::error("back: cannot create {}: {}", o.work_dir, ec.message());
    return kExitError;
  }
  ReclaimStaleWorkspaces(o.back.WorkspaceRoot());
  Counters c;
  Shared sh;
  WindowQueue queue({static_cast<size_t>(o.back.max_queue_windows), o.back.merge_gap_s, o.back.merge_max_frames});
  const Spool spool(o.spool ? (fs::path(o.work_dir) / "spool").string() : "");
  std::unique_ptr<WindowReceiver> rx;
  std::unique_ptr<SubmapSender> tx;
  try {
    rx = std::make_unique<WindowReceiver>(o.ipc);
    tx = std::make_unique<SubmapSender>(o.ipc, SubmapSource::kBack);
  } catch (const std::exception& e) {  // IpcError: another live producer, foreign layout
    spdlog::error("back: {}", e.what());
    WriteStats(o.work_dir, StatsJson(c, sh, queue, false));
    return kExitError;
  }
  if (o.keep_segments) tx->ring().KeepSegmentOnClose();
  // Windows an earlier rumi-back received but did not finish: the one it was
  // building is retried once, the rest as they were.
  std::map<int64_t, int> attempts;
  for (ImageWindow& w : spool.Load()) {
    const int a = spool.Attempts(w.id);
    if (a >= 2) {
      spdlog::error("back: window {} was being built when rumi-back died, twice: dropped", w.id);
      spool.Remove(w.id);
      std::lock_guard<std::mutex> l(sh.mutex);
      ++sh.spool_dropped;
      continue;
    }
    spdlog::info("back: window {} ({} frames) from the spool{}", w.id, w.frames.size(),
                 a == 1 ? ": rumi-back died while building it; retrying it once" : "");
    attempts[w.id] = a;
    Enqueue(std::move(w), &queue, spool, o.back, /*retry=*/a == 1);
  }
  spdlog::info("back: instance {}: windows from {}, submaps to {}, queue {} windows{}", o.ipc.instance,
               rx->ring().name(), tx->ring().name(), o.back.max_queue_windows, spool.enabled() ? ", spooled" : "");
  if (!WriteStats(o.work_dir, StatsJson(c, sh, queue, false))) return kExitError;
  Notifier notifier;
  notifier.Ready();

  std::atomic<bool> reporting_done{false};
  std::thread reporter(ReportLoop, &sh, &queue, &reporting_done);
  std::thread receiver(ReceiveLoop, std::cref(o), rx.get(), tx.get(), &queue, &spool, &sh, stop);
  BackSubmapBuilder builder(o.back, o.first_submap_id);  // one builder: submap ids stay unique across windows
  const std::function<void(const std::string&)> stage = [&sh](const std::string& s) {
    std::lock_guard<std::mutex> l(sh.mutex);
    sh.stage = s;
  };
  builder.set_stage_callback(stage);
  bool stats_ok = true, interrupted = false;
  for (;;) {
    if (sh.abort.load()) {
      interrupted = queue.size() > 0;
      break;
    }
    ImageWindow w;
    std::vector<int64_t> joined;
    if (!queue.Pop(&w, std::chrono::milliseconds(100), &joined)) {
      std::lock_guard<std::mutex> l(sh.mutex);
      if (sh.receiver_done && queue.size() == 0) break;
      continue;
    }
    const int attempt = spool.Start(w.id);
    {
      std::lock_guard<std::mutex> l(sh.mutex);
      sh.building = w.id;
      sh.building_frames = static_cast<int>(w.frames.size());
      sh.stage = "preparing";
      sh.building_since = Clock::now();
    }
    // Under rumid a window's back submaps are numbered from its id: a window
    // built again after a restart replaces its earlier submaps in the map.
    if (spool.enabled()) builder.set_next_submap_id(w.id * kSubmapsPerWindow);
    const Timestamp started = WallNowNs();
    BackResult r;
    if (o.remote && o.remote->Build(w, builder.next_submap_id(), &sh.abort, stage, &r)) {
      // Remote ids follow on from the builder's: the next window's stay unique.
      for (const Submap& s : r.submaps) builder.set_next_submap_id(std::max(builder.next_submap_id(), s.id + 1));
    } else {
      const BackResult::Remote tried = r.remote;  // mode both: offered, nobody claimed it
      r = builder.Build(w, &sh.abort);
      r.remote = tried;
    }
    WindowRecord rec;
    rec.started = started;
    rec.finished = WallNowNs();
    rec.window_id = w.id;
    rec.status = r.status;
    rec.message = r.message;
    rec.frames = r.num_frames;
    rec.registered = r.num_registered;
    rec.attempt = attempt;
    rec.joined = joined;
    rec.retried = r.retried;
    rec.retry_kept = r.retry_kept;
    rec.matched_pairs = r.matched_pairs;
    rec.filled = r.filled;
    rec.fill_kept = r.fill_kept;
    rec.times = r.times;
    rec.remote = r.remote;
    c.seconds += r.times.total_s;
    // The builder logs the outcome and warnings; a failure sends nothing.
    if (!r.ok() && r.status != BackStatus::kCancelled)
      spdlog::error("back: window {} failed ({}); no submap sent", w.id, ToString(r.status));
    bool all_sent = true;
    for (const Submap& s : r.submaps) {
      const PushStatus st = SendWithRetry(tx.get(), s, o.back.wait_for_consumer_s, &sh.abort);
      all_sent &= st == PushStatus::kOk;
      if (st == PushStatus::kOk) {
        ++c.submaps_sent;
        rec.submap_ids.push_back(s.id);
        std::vector<std::string> stamps;
        for (const Keyframe& kf : s.keyframes) stamps.push_back(FormatSeconds(kf.timestamp));
        rec.submap_stamps.push_back(std::move(stamps));
        spdlog::info("back: sent back submap {} ({} keyframes, {} points)", s.id, s.keyframes.size(),
                     s.points.size());
      } else {
        ++c.submaps_dropped;
        spdlog::error("back: back submap {} not sent: {}", s.id, ToString(st));
      }
    }
    if (r.status == BackStatus::kCancelled || !all_sent) {
      interrupted = r.status == BackStatus::kCancelled;
      spool.Keep(w.id, attempt);  // stays in the spool: a restarted back builds it
      if (!all_sent && spool.enabled())
        spdlog::warn("back: window {}: not every submap reached the manager; kept in the spool", w.id);
    } else {
      spool.Remove(w.id);
      for (int64_t j : joined) spool.Remove(j);
    }
    {
      std::lock_guard<std::mutex> l(sh.mutex);
      sh.building = -1;
      (r.ok() ? sh.built : sh.failed)++;
    }
    c.windows.push_back(std::move(rec));
    stats_ok &= WriteStats(o.work_dir, StatsJson(c, sh, queue, false));
    if (interrupted) break;
  }
  sh.abort.store(true);  // the receiver too, if the worker ended first
  receiver.join();
  const bool by_signal = stop && stop->load();
  ProducerEnd end;
  {
    std::lock_guard<std::mutex> l(sh.mutex);
    end = sh.producer_end;
  }
  const bool stream_over = StreamOver(o, end);
  const bool work_done = stream_over && !interrupted && queue.size() == 0;
  if (work_done && !sh.peer_gone.load()) {
    spdlog::info("back: window producer {}, queue empty: done", ToString(end));
    WaitForConsumer(tx->ring(), o.back.wait_for_consumer_s, stop);
  } else if (by_signal) {
    spdlog::info("back: stop requested before the work was done (producer {}, {} window(s) waiting{}); closing",
                 ToString(end), queue.size(), interrupted ? ", one cancelled" : "");
  }
  reporting_done.store(true);
  reporter.join();
  notifier.Stopping();
  const nlohmann::ordered_json j = StatsJson(c, sh, queue, by_signal);
  stats_ok &= WriteStats(o.work_dir, j);
  spdlog::info("back: {} windows received, {} built ({} ok, {} failed, {} dropped), {} submaps sent, {:.1f} s",
               j["windows_received"].get<uint64_t>(), j["windows"].get<uint64_t>(), j["windows_done"].get<uint64_t>(),
               j["windows_failed"].get<uint64_t>(), j["windows_dropped"].get<uint64_t>(), c.submaps_sent, c.seconds);
  tx.reset();  // marks the channel closed (and removes the segment unless kept)
  rx.reset();
  if (!stats_ok) return kExitError;
  if (sh.peer_gone.load()) return kExitPeerGone;
  return work_done ? kExitDone : kExitStopped;
}

}  // namespace rumi
