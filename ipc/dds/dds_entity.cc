#include "ipc/dds/dds_entity.h"

#include <map>
#include <mutex>
#include <utility>

namespace rumi {

std::string DdsError(dds_return_t rc) { return std::string(dds_strretcode(rc)) + " (" + std::to_string(rc) + ")"; }

dds_qos_t* CreateQos(DdsQosKind kind, double max_blocking_s) {
  dds_qos_t* q = dds_create_qos();
  const dds_duration_t block = static_cast<dds_duration_t>(max_blocking_s * 1e9);
  switch (kind) {
    case DdsQosKind::kState:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, block);
      dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      break;
    case DdsQosKind::kEvents:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, block);
      dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 64);
      break;
    case DdsQosKind::kStream:
      dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      break;
    case DdsQosKind::kRpc:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, block);
      dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
      break;
  }
  return q;
}

dds_entity_t CreateParticipant(const DdsOptions& o, std::string* why) {
  // Cyclone refuses a second dds_create_domain for one id in a process.
  static std::mutex mutex;
  static std::map<int, std::string> configured;
  const std::string xml = DomainConfigXml(o);
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = configured.find(o.domain_id);
    if (it == configured.end()) {
      const dds_entity_t d = dds_create_domain(static_cast<dds_domainid_t>(o.domain_id), xml.c_str());
      if (d < 0) {
        if (why)
          *why = "cannot create DDS domain " + std::to_string(o.domain_id) + " on interface '" + o.interface +
                 "': " + DdsError(d);
        return d;
      }
      configured.emplace(o.domain_id, xml);
    } else if (it->second != xml) {
      if (why) *why = "DDS domain " + std::to_string(o.domain_id) + " is configured differently in this process";
      return DDS_RETCODE_PRECONDITION_NOT_MET;
    }
  }
  const dds_entity_t p = dds_create_participant(static_cast<dds_domainid_t>(o.domain_id), nullptr, nullptr);
  if (p < 0 && why) *why = "cannot create a DDS participant on domain " + std::to_string(o.domain_id) + ": " + DdsError(p);
  return p;
}

dds_entity_t CreateTopic(dds_entity_t participant, const dds_topic_descriptor_t* desc, const std::string& name,
                         std::string* why) {
  const dds_entity_t t = dds_create_topic(participant, desc, name.c_str(), nullptr, nullptr);
  if (t < 0 && why) *why = "cannot create DDS topic '" + name + "': " + DdsError(t);
  return t;
}

dds_entity_t CreateWriter(dds_entity_t participant, dds_entity_t topic, DdsQosKind kind, double max_blocking_s,
                          std::string* why) {
  dds_qos_t* q = CreateQos(kind, max_blocking_s);
  const dds_entity_t w = dds_create_writer(participant, topic, q, nullptr);
  dds_delete_qos(q);
  if (w < 0 && why) *why = "cannot create a DDS writer: " + DdsError(w);
  return w;
}

dds_entity_t CreateReader(dds_entity_t participant, dds_entity_t topic, DdsQosKind kind, std::string* why) {
  dds_qos_t* q = CreateQos(kind);
  const dds_entity_t r = dds_create_reader(participant, topic, q, nullptr);
  dds_delete_qos(q);
  if (r < 0 && why) *why = "cannot create a DDS reader: " + DdsError(r);
  return r;
}

}  // namespace rumi
