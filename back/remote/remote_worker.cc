#include "back/remote/remote_worker.h"

#include <chrono>
#include <mutex>
#include <thread>

#include "back/back_result_codec.h"
#include "back/back_submap_builder.h"
#include "back/colmap_workspace.h"
#include "back/remote/remote_protocol.h"
#include "common/logging.h"
#include "common/process/exit_codes.h"
#include "ipc/window_codec.h"

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct OfferInfo {
  int64_t window_id = -1;
  int attempt = 0;
  int64_t first_submap_id = 0;
  int frames = 0;
};
struct GrantInfo {
  int64_t window_id = -1;
  int attempt = 0;
  std::string worker;
};

class Worker {
 public:
  Worker(const RemoteWorkerOptions& o, const std::atomic<bool>* stop)
      : o_(o), stop_(stop), name_(o.name.empty() ? DefaultWorkerName() : o.name), builder_(o.back) {}

  bool Open(std::string* why) {
    if (!ep_.Open(o_.dds, o_.instance, why)) return false;
    const dds_entity_t pp = ep_.participant.get();
    offer_r_ = DdsEntity(CreateReader(pp, ep_.offer, DdsQosKind::kState, why));
    grant_r_ = DdsEntity(CreateReader(pp, ep_.grant, DdsQosKind::kState, why));
    claim_w_ = DdsEntity(CreateWriter(pp, ep_.claim, DdsQosKind::kRpc, 1.0, why));
    result_w_ = DdsEntity(CreateWriter(pp, ep_.result, DdsQosKind::kRpc, 1.0, why));
    progress_w_ = DdsEntity(CreateWriter(pp, ep_.progress, DdsQosKind::kStream, 0.0, why));
    sub_ = DdsEntity(CreatePartitioned(pp, name_, /*publisher=*/false, why));
    window_r_ = DdsEntity(sub_.ok() ? CreateReader(sub_.get(), ep_.window, DdsQosKind::kRpc, why) : 0);
    return offer_r_.ok() && grant_r_.ok() && claim_w_.ok() && result_w_.ok() && progress_w_.ok() && window_r_.ok();
  }

  int Run() {
    spdlog::info("back worker {}: waiting for windows on {} (DDS domain {}, interface '{}')", name_,
                 RemoteTopicsFor(o_.dds, o_.instance).offer, o_.dds.domain_id, o_.dds.interface);
    int64_t claimed = -1;  // the last (window, attempt) claimed
    int claimed_attempt = 0;
    while (!stopped()) {
      Poll();
      if (offer_.window_id >= 0 && (claimed != offer_.window_id || claimed_attempt != offer_.attempt)) {
        claimed = offer_.window_id;
        claimed_attempt = offer_.attempt;
        rumi_back_Claim c{};
        c.version = kRemoteBackVersion;
        c.worker = const_cast<char*>(name_.c_str());
        c.window_id = offer_.window_id;
        c.attempt = offer_.attempt;
        const dds_return_t rc = dds_write(claim_w_.get(), &c);
        if (rc < 0) spdlog::warn("back worker {}: claim not sent: {}", name_, DdsError(rc));
        claimed_offer_ = offer_;
      }
      if (claimed >= 0 && grant_.window_id == claimed && grant_.attempt == claimed_attempt && grant_.worker == name_) {
        Serve(claimed_offer_);
        claimed = -1;
        grant_ = {};
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    spdlog::info("back worker {}: stopped after {} window(s)", name_, built_);
    return kExitStopped;
  }

 private:
  bool stopped() const { return stop_ && stop_->load(); }

  // The latest offer and grant.
  void Poll() {
    std::lock_guard<std::mutex> l(poll_mutex_);
    for (;;) {
      void* s[1] = {nullptr};
      dds_sample_info_t info[1];
      const dds_return_t n = dds_take(offer_r_.get(), s, info, 1, 1);
      if (n <= 0) break;
      const auto& d = *static_cast<const rumi_back_Offer*>(s[0]);
      if (info[0].valid_data && d.version == kRemoteBackVersion)
        offer_ = {d.window_id, d.attempt, d.first_submap_id, d.frames};
      dds_return_loan(offer_r_.get(), s, n);
    }
    for (;;) {
      void* s[1] = {nullptr};
      dds_sample_info_t info[1];
      const dds_return_t n = dds_take(grant_r_.get(), s, info, 1, 1);
      if (n <= 0) break;
      const auto& d = *static_cast<const rumi_back_Grant*>(s[0]);
      if (info[0].valid_data && d.version == kRemoteBackVersion)
        grant_ = {d.window_id, d.attempt, d.worker ? d.worker : ""};
      dds_return_loan(grant_r_.get(), s, n);
    }
  }

  // The window has gone to another attempt (a stop of the dispatcher, or it
  // took this worker for dead), or the dispatcher has been unmatched for a lease.
  bool Superseded(const OfferInfo& job, Clock::time_point* unmatched_since) {
    Poll();
    {
      std::lock_guard<std::mutex> l(poll_mutex_);
      if (grant_.window_id == job.window_id && grant_.attempt > job.attempt) return true;
    }
    dds_subscription_matched_status_t m{};
    dds_get_subscription_matched_status(grant_r_.get(), &m);
    if (m.current_count > 0) {
      *unmatched_since = Clock::time_point{};
    } else if (*unmatched_since == Clock::time_point{}) {
      *unmatched_since = Clock::now();
    } else if (Since(*unmatched_since) > o_.back.remote_lease_s) {
      return true;
    }
    return false;
  }

  void Serve(const OfferInfo& job) {
    const auto start = Clock::now();
    std::mutex m;
    std::string stage = "receiving";
    std::atomic<bool> done{false}, cancel{false};
    // Progress every second, and the cancel watch while COLMAP runs.
    std::thread beat([&] {
      Clock::time_point unmatched{};
      auto last = Clock::now() - std::chrono::seconds(2);
      while (!done.load()) {
        if (stopped() || Superseded(job, &unmatched)) cancel.store(true);
        if (Since(last) >= 1.0) {
          last = Clock::now();
          std::string s;
          {
            std::lock_guard<std::mutex> l(m);
            s = stage;
          }
          rumi_back_Progress p{};
          p.version = kRemoteBackVersion;
          p.worker = const_cast<char*>(name_.c_str());
          p.window_id = job.window_id;
          p.attempt = job.attempt;
          p.stage = const_cast<char*>(s.c_str());
          p.elapsed_s = Since(start);
          dds_write(progress_w_.get(), &p);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    });
    const auto set_stage = [&](const std::string& s) {
      std::lock_guard<std::mutex> l(m);
      stage = s;
    };
    const auto finish = [&](const std::string& why) {
      done.store(true);
      beat.join();
      if (!why.empty()) spdlog::warn("back worker {}: window {} attempt {}: {}", name_, job.window_id, job.attempt, why);
    };
    ChunkAssembler got;
    got.Reset(name_, job.window_id, job.attempt);
    auto last_chunk = Clock::now();
    while (!got.complete()) {
      if (cancel.load()) return finish("given up while receiving (stopped or taken back)");
      if (Since(last_chunk) > o_.back.remote_lease_s) return finish("the window stopped coming; given up");
      void* s[1] = {nullptr};
      dds_sample_info_t info[1];
      const dds_return_t n = dds_take(window_r_.get(), s, info, 1, 1);
      if (n <= 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        continue;
      }
      if (info[0].valid_data && got.Add(*static_cast<const rumi_back_Part*>(s[0]))) last_chunk = Clock::now();
      dds_return_loan(window_r_.get(), s, n);
    }
    const std::vector<uint8_t> bytes = got.Bytes();
    ImageWindow w;
    std::string why;
    BackResult r;
    if (!DecodeWindow(bytes.data(), bytes.size(), &w, /*in_place=*/false, &why)) {
      r.window_id = job.window_id;
      r.status = BackStatus::kInvalidWindow;
      r.message = "the window did not decode on worker " + name_ + ": " + why;
    } else {
      spdlog::info("back worker {}: building window {} ({} frames, attempt {})", name_, w.id, w.frames.size(),
                   job.attempt);
      builder_.set_next_submap_id(job.first_submap_id);
      builder_.set_stage_callback(set_stage);
      r = builder_.Build(w, &cancel);
    }
    if (r.status == BackStatus::kCancelled) return finish("build cancelled (stopped or taken back)");
    set_stage("sending");
    const std::vector<uint8_t> out = EncodeBackResult(r);
    const bool sent = SendChunks(result_w_.get(), name_, job.window_id, job.attempt, out,
                                 static_cast<size_t>(o_.dds.chunk_bytes), [&] { return !cancel.load(); }, &why);
    ++built_;
    finish(sent ? "" : "result not sent: " + why);
    if (sent)
      spdlog::info("back worker {}: window {} {}: {} submaps, {}/{} registered, {:.1f} s ({:.1f} MB in, {:.2f} MB out)",
                   name_, job.window_id, ToString(r.status), r.submaps.size(), r.num_registered, r.num_frames,
                   Since(start), bytes.size() / 1e6, out.size() / 1e6);
  }

  const RemoteWorkerOptions& o_;
  const std::atomic<bool>* stop_;
  std::string name_;
  BackSubmapBuilder builder_;
  RemoteEndpoints ep_;
  DdsEntity offer_r_, grant_r_, claim_w_, result_w_, progress_w_, sub_, window_r_;
  std::mutex poll_mutex_;
  OfferInfo offer_, claimed_offer_;
  GrantInfo grant_;
  int built_ = 0;
};

}  // namespace

int RunRemoteWorker(const RemoteWorkerOptions& o, const std::atomic<bool>* stop) {
  ReclaimStaleWorkspaces(o.back.WorkspaceRoot());
  Worker worker(o, stop);
  std::string why;
  if (!worker.Open(&why)) {
    spdlog::error("back worker: {}", why);
    return kExitError;
  }
  return worker.Run();
}

}  // namespace rumi
