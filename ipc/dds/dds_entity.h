#pragma once
// Small RAII helpers over Cyclone's C API: an entity that is deleted with
// its owner, QoS objects, and the participant on rumi's configured domain.
#include <dds/dds.h>

#include <string>

#include "ipc/dds/dds_options.h"

namespace rumi {

class DdsEntity {
 public:
  DdsEntity() = default;
  explicit DdsEntity(dds_entity_t e) : e_(e) {}
  ~DdsEntity() { Reset(); }
  DdsEntity(DdsEntity&& o) noexcept : e_(o.e_) { o.e_ = 0; }
  DdsEntity& operator=(DdsEntity&& o) noexcept {
    if (this != &o) {
      Reset();
      e_ = o.e_;
      o.e_ = 0;
    }
    return *this;
  }
  DdsEntity(const DdsEntity&) = delete;
  DdsEntity& operator=(const DdsEntity&) = delete;
  dds_entity_t get() const { return e_; }
  bool ok() const { return e_ > 0; }
  void Reset() {
    if (e_ > 0) dds_delete(e_);
    e_ = 0;
  }

 private:
  dds_entity_t e_ = 0;
};

// What a topic is for, as QoS:
//   kState   reliable, transient-local, last value (late joiners get it)
//   kEvents  reliable, transient-local, the last 64
//   kStream  best effort, last value (the pose at frame rate)
//   kRpc     reliable, volatile, keep all (requests and reply chunks)
enum class DdsQosKind { kState, kEvents, kStream, kRpc };
dds_qos_t* CreateQos(DdsQosKind kind, double max_blocking_s = 0.1);  // dds_delete_qos it

// A participant on o.domain_id. The domain is created once per process with
// DomainConfigXml(o); later participants share it (a second, different
// configuration of the same domain in one process is refused). <= 0 with
// *why on failure (a bad interface, a domain that exists differently).
dds_entity_t CreateParticipant(const DdsOptions& o, std::string* why);

// A topic + reader or writer, or 0 with *why naming the topic.
dds_entity_t CreateTopic(dds_entity_t participant, const dds_topic_descriptor_t* desc, const std::string& name,
                         std::string* why);
dds_entity_t CreateWriter(dds_entity_t participant, dds_entity_t topic, DdsQosKind kind, double max_blocking_s,
                          std::string* why);
dds_entity_t CreateReader(dds_entity_t participant, dds_entity_t topic, DdsQosKind kind, std::string* why);

std::string DdsError(dds_return_t rc);  // "DDS_RETCODE_...: text"

}  // namespace rumi
