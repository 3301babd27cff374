#include "back/back_ipc_main.h"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "back/back_submap_builder.h"
#include "back/window_queue.h"
#include "common/logging.h"
#include "common/timestamp.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

enum class ProducerEnd { kRunning, kClosed, kDied, kNeverAppeared, kStopped };
const char* ToString(ProducerEnd e) {
  switch (e) {
    case ProducerEnd::kRunning: return "running";
    case ProducerEnd::kClosed: return "closed";
    case ProducerEnd::kDied: return "died";
    case ProducerEnd::kNeverAppeared: return "never_appeared";
    case ProducerEnd::kStopped: return "stopped";
  }
  return "?";
}

// What back_stats.json reports. Written by the worker (main) thread only; the
// receiver's counters are atomics.
struct WindowRecord {
  int64_t window_id = -1;
  BackStatus status = BackStatus::kInvalidWindow;
  std::string message;
  int frames = 0, registered = 0;
  bool retried = false, retry_kept = false;  // lower SIFT threshold tried / kept
  std::vector<int64_t> submap_ids;
  std::vector<std::vector<std::string>> submap_stamps;  // per sent submap: its keyframes' timestamps
  BackStepTimes times;
};

struct Counters {
  std::atomic<uint64_t> received{0};
  std::atomic<uint64_t> decode_errors{0};
  std::atomic<int> producer_end{static_cast<int>(ProducerEnd::kRunning)};
  uint64_t submaps_sent = 0, submaps_dropped = 0;
  double seconds = 0.0;  // wall seconds inside BackSubmapBuilder::Build
  std::vector<WindowRecord> windows;
};

nlohmann::ordered_json StatsJson(const Counters& c, uint64_t dropped, bool stopped) {
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
                   {"retried", w.retried},
                   {"retry_kept", w.retry_kept},
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
  return {{"windows", c.windows.size()},  // processed (docs/eval.md contract)
          {"seconds", c.seconds},
          {"windows_received", c.received.load()},
          {"windows_done", done},
          {"windows_failed", failed},
          {"windows_cancelled", cancelled},
          {"windows_dropped", dropped},
          {"windows_undecodable", c.decode_errors.load()},
          {"submaps_sent", c.submaps_sent},
          {"submaps_dropped", c.submaps_dropped},
          {"producer", ToString(static_cast<ProducerEnd>(c.producer_end.load()))},
          {"stopped_by_signal", stopped},
          {"per_window", per}};
}

// Atomic replace, so `rumi eval run` never reads half a file.
bool WriteStats(const std::string& work_dir, const nlohmann::ordered_json& j) {
  const fs::path path = fs::path(work_dir) / "back_stats.json";
  const fs::path tmp = fs::path(work_dir) / "back_stats.json.tmp";
  {
    std::ofstream f(tmp);
    f << j.dump(2) << "\n";
    if (!f) {
      spdlog::error("back: cannot write {}", tmp.string());
      return false;
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    spdlog::error("back: cannot write {}: {}", path.string(), ec.message());
    return false;
  }
  return true;
}

// Pulls windows off the ring into the queue as fast as they come, so the ring
// never fills while COLMAP runs; the queue drops its oldest window instead.
void ReceiveLoop(const BackIpcRunOptions& o, WindowReceiver* rx, WindowQueue* queue, Counters* c,
                 const std::atomic<bool>* stop) {
  const auto start = Clock::now();
  auto last_liveness = start;
  bool seen = false;
  std::string last_error;
  ProducerEnd end = ProducerEnd::kRunning;
  while (end == ProducerEnd::kRunning) {
    if (stop && stop->load()) {
      end = ProducerEnd::kStopped;
      break;
    }
    const uint64_t closed_before = rx->ring().closed_segments();
    ImageWindow w;
    const PopStatus st = rx->Receive(&w, 0.05);
    c->decode_errors.store(rx->decode_errors());
    const bool connected = rx->ring().connected();
    const bool closed = rx->ring().closed_segments() != closed_before;
    if (connected && !seen) spdlog::info("back: window producer attached ({})", rx->ring().name());
    seen |= connected || closed;
    if (st == PopStatus::kOk) {
      c->received.fetch_add(1);
      const size_t frames = w.frames.size();
      const int64_t id = w.id;
      if (!queue->Push(std::move(w))) {
        spdlog::warn("back: queue full ({} windows): dropped the oldest waiting window ({} dropped so far)",
                     o.back.max_queue_windows, queue->dropped());
      }
      spdlog::info("back: received window {} ({} frames), {} waiting", id, frames, queue->size());
      continue;
    }
    if (st == PopStatus::kIncompatible && rx->ring().last_error() != last_error) {
      last_error = rx->ring().last_error();
      spdlog::error("back: windows channel: {}", last_error);
    }
    if (closed && !connected) {
      spdlog::info("back: window producer closed its channel (drained)");
      end = ProducerEnd::kClosed;
    } else if (connected && st == PopStatus::kEmpty && SecondsSince(last_liveness) > 0.5) {
      // A crashed producer leaves its segment behind: dead pid + empty ring.
      last_liveness = Clock::now();
      const RingStats rs = rx->ring().Stats();
      if (rs.producer_pid != 0 && !rs.producer_alive && !rs.closed && rs.head == rs.tail) {
        spdlog::warn("back: window producer (pid {}) died without closing its channel; taking it as finished",
                     rs.producer_pid);
        end = ProducerEnd::kDied;
      }
    } else if (!seen && o.wait_for_producer_s > 0 && SecondsSince(start) > o.wait_for_producer_s) {
      spdlog::warn("back: no window producer appeared within {} s", o.wait_for_producer_s);
      end = ProducerEnd::kNeverAppeared;
    }
    if (st != PopStatus::kOk && st != PopStatus::kEmpty && end == ProducerEnd::kRunning) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // not attached: Receive does not wait
    }
  }
  c->producer_end.store(static_cast<int>(end));
  queue->Close();
}

// The back is not realtime: a full submap ring is retried (the manager reads
// it soon) rather than dropped, up to wait_s.
PushStatus SendWithRetry(SubmapSender* tx, const Submap& s, double wait_s, const std::atomic<bool>* stop) {
  const auto start = Clock::now();
  bool warned = false;
  for (;;) {
    const PushStatus st = tx->Send(s);
    if (st != PushStatus::kDropped) return st;
    if ((stop && stop->load()) || SecondsSince(start) > wait_s) return st;
    if (!warned) {
      spdlog::warn("back: submap ring full; retrying submap {} for up to {} s", s.id, wait_s);
      warned = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

// A producer that closes before the consumer has attached (or read) takes its
// messages with it (the segment is unlinked): wait for the manager first.
void WaitForConsumer(SubmapSender* tx, double wait_s, const std::atomic<bool>* stop) {
  const auto start = Clock::now();
  for (;;) {
    const RingStats rs = tx->ring().Stats();
    if (rs.consumer_alive && rs.tail >= rs.head) {
      spdlog::info("back: manager has read all {} back submap message(s)", rs.head);
      return;
    }
    if (stop && stop->load()) return;
    if (SecondsSince(start) > wait_s) {
      spdlog::warn("back: the back submap consumer {} after {} s ({} of {} messages read); closing anyway",
                   rs.consumer_alive ? "has not read everything" : "never attached", wait_s, rs.tail, rs.head);
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace

int RunBackIpc(const BackIpcRunOptions& o, const std::atomic<bool>* stop) {
  std::error_code ec;
  fs::create_directories(o.work_dir, ec);
  if (ec) {
    spdlog::error("back: cannot create {}: {}", o.work_dir, ec.message());
    return 1;
  }
  Counters c;
  WindowQueue queue(static_cast<size_t>(o.back.max_queue_windows));
  std::unique_ptr<WindowReceiver> rx;
  std::unique_ptr<SubmapSender> tx;
  try {
    rx = std::make_unique<WindowReceiver>(o.ipc);
    tx = std::make_unique<SubmapSender>(o.ipc, SubmapSource::kBack);
  } catch (const std::exception& e) {  // IpcError: another live producer, foreign layout
    spdlog::error("back: {}", e.what());
    WriteStats(o.work_dir, StatsJson(c, 0, false));
    return 1;
  }
  spdlog::info("back: instance {}: windows from {}, submaps to {}, queue {} windows", o.ipc.instance,
               rx->ring().name(), tx->ring().name(), o.back.max_queue_windows);
  if (!WriteStats(o.work_dir, StatsJson(c, 0, false))) return 1;

  std::thread receiver(ReceiveLoop, std::cref(o), rx.get(), &queue, &c, stop);
  BackSubmapBuilder builder(o.back);  // one builder: submap ids stay unique across windows
  const auto stopped = [stop] { return stop && stop->load(); };
  bool stats_ok = true;
  while (!stopped()) {
    ImageWindow w;
    if (!queue.Pop(&w, std::chrono::milliseconds(100))) {
      if (c.producer_end.load() != static_cast<int>(ProducerEnd::kRunning) && queue.size() == 0) break;
      continue;
    }
    const BackResult r = builder.Build(w, stop);
    WindowRecord rec;
    rec.window_id = w.id;
    rec.status = r.status;
    rec.message = r.message;
    rec.frames = r.num_frames;
    rec.registered = r.num_registered;
    rec.retried = r.retried;
    rec.retry_kept = r.retry_kept;
    rec.times = r.times;
    c.seconds += r.times.total_s;
    // The builder logs the outcome and warnings; a failure sends nothing.
    if (!r.ok() && r.status != BackStatus::kCancelled)
      spdlog::error("back: window {} failed ({}); no submap sent", w.id, ToString(r.status));
    for (const Submap& s : r.submaps) {
      const PushStatus st = SendWithRetry(tx.get(), s, o.wait_for_consumer_s, stop);
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
    c.windows.push_back(std::move(rec));
    stats_ok &= WriteStats(o.work_dir, StatsJson(c, queue.dropped(), false));
  }
  receiver.join();
  const bool by_signal = stopped();
  if (by_signal) {
    spdlog::info("back: stop requested; closing channels");
  } else {
    spdlog::info("back: window producer {}, queue empty: done", ToString(static_cast<ProducerEnd>(c.producer_end.load())));
    WaitForConsumer(tx.get(), o.wait_for_consumer_s, stop);
  }
  const nlohmann::ordered_json j = StatsJson(c, queue.dropped(), by_signal);
  stats_ok &= WriteStats(o.work_dir, j);
  spdlog::info("back: {} windows received, {} built ({} ok, {} failed, {} dropped), {} submaps sent, {:.1f} s",
               j["windows_received"].get<uint64_t>(), j["windows"].get<uint64_t>(), j["windows_done"].get<uint64_t>(),
               j["windows_failed"].get<uint64_t>(), j["windows_dropped"].get<uint64_t>(), c.submaps_sent, c.seconds);
  tx.reset();  // marks the channel closed and removes the segment
  rx.reset();
  return stats_ok ? 0 : 1;
}

}  // namespace rumi
