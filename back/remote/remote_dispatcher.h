#pragma once
// The dispatcher side of the remote back (back.mode remote or both): rumi-back
// keeps its queue, spool and ring to the manager, and hands each window to a
// `rumi-back --remote` worker over Cyclone DDS instead of running COLMAP
// itself (protocol: remote_protocol.h). One window is out at a time.
#include <atomic>
#include <map>
#include <memory>
#include <string>

#include "back/back_options.h"
#include "back/back_run.h"
#include "back/remote/remote_protocol.h"

namespace rumi {

class RemoteDispatcher : public RemoteWindowBuilder {
 public:
  // nullptr with *why when the DDS domain or a topic cannot be set up.
  static std::unique_ptr<RemoteDispatcher> Create(const DdsOptions& dds, const std::string& instance,
                                                  const BackOptions& back, std::string* why);
  ~RemoteDispatcher() override;

  bool Build(const ImageWindow& w, int64_t first_submap_id, const std::atomic<bool>* cancel,
             const std::function<void(const std::string&)>& stage, BackResult* result) override;

  uint64_t bytes_sent() const { return bytes_sent_; }
  uint64_t bytes_received() const { return bytes_received_; }

 private:
  RemoteDispatcher(const DdsOptions& dds, const BackOptions& back) : dds_(dds), back_(back) {}
  void Offer(int64_t window_id, int attempt, int frames, uint64_t bytes, int64_t first_submap_id);
  void Grant(int64_t window_id, int attempt, const std::string& worker);
  // Takes the progress samples: the time the given transfer's worker was last heard of.
  void TakeProgress(const std::string& worker, int64_t window_id, int attempt,
                    std::chrono::steady_clock::time_point* last_seen, std::string* stage);

  DdsOptions dds_;
  BackOptions back_;
  RemoteEndpoints ep_;
  DdsEntity offer_w_, claim_r_, grant_w_, result_r_, progress_r_;
  std::map<int64_t, int> attempts_;  // per window: the last attempt offered
  uint64_t bytes_sent_ = 0, bytes_received_ = 0;
};

}  // namespace rumi
