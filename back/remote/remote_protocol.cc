#include "back/remote/remote_protocol.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>

namespace rumi {

RemoteTopicNames RemoteTopicsFor(const DdsOptions& o, const std::string& instance) {
  const std::string p = TopicsFor(o, instance).prefix + "/back/";
  return {p + "offer", p + "claim", p + "grant", p + "window", p + "result", p + "progress"};
}

bool RemoteEndpoints::Open(const DdsOptions& o, const std::string& instance, std::string* why) {
  participant = DdsEntity(CreateParticipant(o, why));
  if (!participant.ok()) return false;
  const RemoteTopicNames n = RemoteTopicsFor(o, instance);
  const dds_entity_t pp = participant.get();
  return (offer = CreateTopic(pp, &rumi_back_Offer_desc, n.offer, why)) > 0 &&
         (claim = CreateTopic(pp, &rumi_back_Claim_desc, n.claim, why)) > 0 &&
         (grant = CreateTopic(pp, &rumi_back_Grant_desc, n.grant, why)) > 0 &&
         (window = CreateTopic(pp, &rumi_back_Part_desc, n.window, why)) > 0 &&
         (result = CreateTopic(pp, &rumi_back_Part_desc, n.result, why)) > 0 &&
         (progress = CreateTopic(pp, &rumi_back_Progress_desc, n.progress, why)) > 0;
}

dds_entity_t CreatePartitioned(dds_entity_t participant, const std::string& partition, bool publisher,
                               std::string* why) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_partition1(q, partition.c_str());
  const dds_entity_t e =
      publisher ? dds_create_publisher(participant, q, nullptr) : dds_create_subscriber(participant, q, nullptr);
  dds_delete_qos(q);
  if (e < 0 && why) *why = "cannot create a DDS " + std::string(publisher ? "publisher" : "subscriber") +
                           " in partition '" + partition + "': " + DdsError(e);
  return e;
}

bool SendChunks(dds_entity_t writer, const std::string& worker, int64_t window_id, int attempt,
                const std::vector<uint8_t>& bytes, size_t chunk_bytes, const std::function<bool()>& keep_going,
                std::string* why) {
  const size_t n = std::max<size_t>(1, (bytes.size() + chunk_bytes - 1) / chunk_bytes);
  for (size_t i = 0; i < n; ++i) {
    rumi_back_Part c{};
    c.version = kRemoteBackVersion;
    c.worker = const_cast<char*>(worker.c_str());
    c.window_id = window_id;
    c.attempt = attempt;
    c.chunk = static_cast<uint32_t>(i);
    c.chunks = static_cast<uint32_t>(n);
    const size_t at = i * chunk_bytes, len = std::min(chunk_bytes, bytes.size() - std::min(at, bytes.size()));
    c.data._maximum = c.data._length = static_cast<uint32_t>(len);
    c.data._buffer = len ? const_cast<uint8_t*>(bytes.data() + at) : nullptr;
    c.data._release = false;
    for (;;) {
      const dds_return_t rc = dds_write(writer, &c);
      if (rc == DDS_RETCODE_OK) break;
      if (rc != DDS_RETCODE_TIMEOUT || !keep_going()) {
        if (why) *why = "chunk " + std::to_string(i) + " of " + std::to_string(n) + " not sent: " + DdsError(rc);
        return false;
      }
    }
  }
  return true;
}

void ChunkAssembler::Reset(const std::string& worker, int64_t window_id, int attempt) {
  worker_ = worker;
  window_id_ = window_id;
  attempt_ = attempt;
  chunks_ = 0;
  got_.clear();
}

bool ChunkAssembler::Add(const rumi_back_Part& c) {
  if (c.version != kRemoteBackVersion || c.window_id != window_id_ || c.attempt != attempt_ || !c.worker ||
      worker_ != c.worker || c.chunks == 0 || c.chunk >= c.chunks || (chunks_ && c.chunks != chunks_))
    return false;
  chunks_ = c.chunks;
  got_[c.chunk].assign(c.data._buffer, c.data._buffer + c.data._length);
  return true;
}

std::vector<uint8_t> ChunkAssembler::Bytes() const {
  std::vector<uint8_t> out;
  for (const auto& [i, b] : got_) out.insert(out.end(), b.begin(), b.end());
  return out;
}

std::string DefaultWorkerName() {
  char host[256] = {0};
  if (::gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;
  return std::string(host[0] ? host : "host") + "-" + std::to_string(::getpid());
}

}  // namespace rumi
