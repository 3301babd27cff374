#include "back/remote/remote_dispatcher.h"

#include <chrono>
#include <thread>

#include "back/back_result_codec.h"
#include "common/logging.h"
#include "ipc/window_codec.h"

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
void Nap() { std::this_thread::sleep_for(std::chrono::milliseconds(10)); }

BackResult Cancelled(int64_t window_id) {
  BackResult r;
  r.window_id = window_id;
  r.status = BackStatus::kCancelled;
  r.message = "cancelled while a remote worker had it";
  return r;
}

}  // namespace

std::unique_ptr<RemoteDispatcher> RemoteDispatcher::Create(const DdsOptions& dds, const std::string& instance,
                                                           const BackOptions& back, std::string* why) {
  std::unique_ptr<RemoteDispatcher> d(new RemoteDispatcher(dds, back));
  if (!d->ep_.Open(dds, instance, why)) return nullptr;
  const dds_entity_t pp = d->ep_.participant.get();
  d->offer_w_ = DdsEntity(CreateWriter(pp, d->ep_.offer, DdsQosKind::kState, 1.0, why));
  d->grant_w_ = DdsEntity(CreateWriter(pp, d->ep_.grant, DdsQosKind::kState, 1.0, why));
  d->claim_r_ = DdsEntity(CreateReader(pp, d->ep_.claim, DdsQosKind::kRpc, why));
  d->result_r_ = DdsEntity(CreateReader(pp, d->ep_.result, DdsQosKind::kRpc, why));
  d->progress_r_ = DdsEntity(CreateReader(pp, d->ep_.progress, DdsQosKind::kStream, why));
  if (!d->offer_w_.ok() || !d->grant_w_.ok() || !d->claim_r_.ok() || !d->result_r_.ok() || !d->progress_r_.ok())
    return nullptr;
  d->Offer(-1, 0, 0, 0, 0);
  spdlog::info("back: remote workers: offering windows on {} (DDS domain {}, interface '{}'), mode {}",
               RemoteTopicsFor(dds, instance).offer, dds.domain_id, dds.interface, back.mode);
  return d;
}

RemoteDispatcher::~RemoteDispatcher() {
  if (offer_w_.ok()) Offer(-1, 0, 0, 0, 0);
}

void RemoteDispatcher::Offer(int64_t window_id, int attempt, int frames, uint64_t bytes, int64_t first_submap_id) {
  rumi_back_Offer o{};
  o.version = kRemoteBackVersion;
  o.window_id = window_id;
  o.attempt = attempt;
  o.frames = frames;
  o.bytes = bytes;
  o.first_submap_id = first_submap_id;
  const dds_return_t rc = dds_write(offer_w_.get(), &o);
  if (rc < 0) spdlog::warn("back: offer of window {} not published: {}", window_id, DdsError(rc));
}

void RemoteDispatcher::Grant(int64_t window_id, int attempt, const std::string& worker) {
  rumi_back_Grant g{};
  g.version = kRemoteBackVersion;
  g.window_id = window_id;
  g.attempt = attempt;
  g.worker = const_cast<char*>(worker.c_str());
  const dds_return_t rc = dds_write(grant_w_.get(), &g);
  if (rc < 0) spdlog::warn("back: grant of window {} not published: {}", window_id, DdsError(rc));
}

void RemoteDispatcher::TakeProgress(const std::string& worker, int64_t window_id, int attempt,
                                    Clock::time_point* last_seen, std::string* stage) {
  for (;;) {
    void* samples[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_take(progress_r_.get(), samples, info, 1, 1);
    if (n <= 0) return;
    const auto& p = *static_cast<const rumi_back_Progress*>(samples[0]);
    if (info[0].valid_data && p.worker && worker == p.worker && p.window_id == window_id && p.attempt == attempt) {
      *last_seen = Clock::now();
      if (stage && p.stage) *stage = p.stage;
    }
    dds_return_loan(progress_r_.get(), samples, n);
  }
}

bool RemoteDispatcher::Build(const ImageWindow& w, int64_t first_submap_id, const std::atomic<bool>* cancel,
                             const std::function<void(const std::string&)>& stage, BackResult* result) {
  const std::vector<uint8_t> bytes = EncodeWindow(w, back_.remote_png ? WindowPixels::kPng : WindowPixels::kRaw);
  const auto cancelled = [&] { return cancel && cancel->load(); };
  const auto say = [&](const std::string& s) {
    if (stage) stage(s);
  };
  BackResult::Remote cost;  // summed over the attempts
  for (;;) {
    const int attempt = ++attempts_[w.id];
    ++cost.offers;
    Offer(w.id, attempt, static_cast<int>(w.frames.size()), bytes.size(), first_submap_id);
    say("offered to remote workers");
    // The first claim of this attempt wins.
    std::string worker;
    const auto offered = Clock::now();
    while (worker.empty()) {
      if (cancelled()) {
        Offer(-1, 0, 0, 0, 0);
        *result = Cancelled(w.id);
        return true;
      }
      void* samples[1] = {nullptr};
      dds_sample_info_t info[1];
      const dds_return_t n = dds_take(claim_r_.get(), samples, info, 1, 1);
      if (n > 0) {
        const auto& c = *static_cast<const rumi_back_Claim*>(samples[0]);
        if (info[0].valid_data && c.version == kRemoteBackVersion && c.window_id == w.id && c.attempt == attempt &&
            c.worker && c.worker[0])
          worker = c.worker;
        dds_return_loan(claim_r_.get(), samples, n);
        continue;
      }
      if (back_.mode == "both" && Since(offered) > back_.remote_claim_timeout_s) {
        Offer(-1, 0, 0, 0, 0);
        cost.claim_wait_s += Since(offered);
        result->remote = cost;
        spdlog::info("back: no remote worker claimed window {} within {} s: building it here", w.id,
                     back_.remote_claim_timeout_s);
        return false;
      }
      Nap();
    }
    cost.claim_wait_s += Since(offered);
    Grant(w.id, attempt, worker);
    Offer(-1, 0, 0, 0, 0);
    spdlog::info("back: window {} ({} frames, {:.1f} MB{}) granted to remote worker {} (attempt {})", w.id,
                 w.frames.size(), bytes.size() / 1e6,
                 back_.remote_png ? fmt::format(" with PNG frames, {:.1f} MB raw", EncodedWindowSize(w) / 1e6) : "",
                 worker, attempt);
    auto last_seen = Clock::now();
    std::string remote_stage = "receiving";
    const auto alive = [&] {
      TakeProgress(worker, w.id, attempt, &last_seen, &remote_stage);
      return !cancelled() && Since(last_seen) < back_.remote_lease_s;
    };
    // The window goes to the granted worker alone: its partition.
    std::string why;
    DdsEntity pub(CreatePartitioned(ep_.participant.get(), worker, /*publisher=*/true, &why));
    DdsEntity writer(pub.ok() ? CreateWriter(pub.get(), ep_.window, DdsQosKind::kRpc, 1.0, &why) : 0);
    if (!writer.ok()) {
      spdlog::error("back: window {}: {}", w.id, why);
      continue;
    }
    say("sending to " + worker);
    bool matched = false;
    while (alive()) {
      dds_publication_matched_status_t m{};
      dds_get_publication_matched_status(writer.get(), &m);
      if ((matched = m.current_count > 0)) break;
      Nap();
    }
    if (matched && SendChunks(writer.get(), worker, w.id, attempt, bytes, static_cast<size_t>(dds_.chunk_bytes),
                              alive, &why)) {
      bytes_sent_ += bytes.size();
      cost.bytes_out += bytes.size();
      ChunkAssembler got;
      got.Reset(worker, w.id, attempt);
      while (!got.complete() && alive()) {
        say("remote " + worker + ": " + remote_stage);
        void* samples[1] = {nullptr};
        dds_sample_info_t info[1];
        const dds_return_t n = dds_take(result_r_.get(), samples, info, 1, 1);
        if (n <= 0) {
          Nap();
          continue;
        }
        const auto& c = *static_cast<const rumi_back_Part*>(samples[0]);
        if (info[0].valid_data && got.Add(c))
          last_seen = Clock::now();
        else if (info[0].valid_data && c.window_id == w.id && c.attempt < attempt && c.chunk == 0)
          spdlog::info("back: a late result of window {} attempt {} dropped (attempt {} is out)", w.id, c.attempt,
                       attempt);
        dds_return_loan(result_r_.get(), samples, n);
      }
      if (got.complete()) {
        const std::vector<uint8_t> rb = got.Bytes();
        bytes_received_ += rb.size();
        cost.bytes_in += rb.size();
        BackResult r;
        if (!DecodeBackResult(rb.data(), rb.size(), &r, &why)) {
          spdlog::error("back: window {}: the result from {} does not decode ({}); offered again", w.id, worker, why);
          continue;
        }
        r.window_id = w.id;
        cost.worker = worker;
        r.remote = cost;
        spdlog::info("back: window {} built by {}: {} ({} submaps, {}/{} registered, {:.1f} s; {:.1f} MB out, "
                     "{:.2f} MB back)",
                     w.id, worker, ToString(r.status), r.submaps.size(), r.num_registered, r.num_frames,
                     r.times.total_s, bytes.size() / 1e6, rb.size() / 1e6);
        *result = std::move(r);
        return true;
      }
    } else if (!cancelled()) {
      spdlog::warn("back: window {} could not reach worker {}{}", w.id, worker, why.empty() ? "" : ": " + why);
    }
    if (cancelled()) {
      Grant(w.id, attempt + 1, "");  // a worker still building it stops
      *result = Cancelled(w.id);
      return true;
    }
    spdlog::warn("back: remote worker {} silent for {} s on window {}: offered again (attempt {})", worker,
                 back_.remote_lease_s, w.id, attempt + 1);
  }
}

}  // namespace rumi
