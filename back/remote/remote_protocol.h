#pragma once
// What the dispatcher (rumi-back, back.mode remote/both) and the workers
// (`rumi-back --remote`) share: the topics under <prefix>/back/, the
// protocol version, and chunked transfer of encoded windows and results.
// The protocol (docs/back.md "Remote workers"): the dispatcher offers one
// window at a time; free workers claim it; the first claim is granted; the
// window goes to that worker alone (its partition); the worker reports
// progress every second while it receives, builds and sends; the result
// comes back in chunks. A worker silent for back.remote_lease_s is taken for
// dead and the window is offered again under the next attempt number; a
// result of an older attempt is dropped, so each window is built once.
#include <dds/dds.h>

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "ipc/dds/dds_entity.h"
#include "ipc/dds/dds_options.h"
#include "remote_back.h"  // idlc

namespace rumi {

constexpr uint32_t kRemoteBackVersion = 1;

struct RemoteTopicNames {
  std::string offer, claim, grant, window, result, progress;
};
RemoteTopicNames RemoteTopicsFor(const DdsOptions& o, const std::string& instance);

// The participant and the six topics of one instance.
struct RemoteEndpoints {
  DdsEntity participant;
  dds_entity_t offer = 0, claim = 0, grant = 0, window = 0, result = 0, progress = 0;
  bool Open(const DdsOptions& o, const std::string& instance, std::string* why);
};

// A publisher or subscriber in one partition (the granted worker's).
dds_entity_t CreatePartitioned(dds_entity_t participant, const std::string& partition, bool publisher,
                               std::string* why);

// Writes `bytes` as Part samples of at most chunk_bytes. A write that
// times out (a reader not keeping up) is retried while keep_going() holds.
bool SendChunks(dds_entity_t writer, const std::string& worker, int64_t window_id, int attempt,
                const std::vector<uint8_t>& bytes, size_t chunk_bytes, const std::function<bool()>& keep_going,
                std::string* why);

// Collects the chunks of one transfer (window_id, attempt, worker).
class ChunkAssembler {
 public:
  void Reset(const std::string& worker, int64_t window_id, int attempt);
  // False when the chunk belongs to another transfer (not taken).
  bool Add(const rumi_back_Part& c);
  bool complete() const { return chunks_ > 0 && got_.size() == chunks_; }
  std::vector<uint8_t> Bytes() const;
  size_t received() const { return got_.size(); }

 private:
  std::string worker_;
  int64_t window_id_ = -1;
  int attempt_ = 0;
  uint32_t chunks_ = 0;
  std::map<uint32_t, std::vector<uint8_t>> got_;
};

// "<host>-<pid>": a worker's name on the wire.
std::string DefaultWorkerName();

}  // namespace rumi
