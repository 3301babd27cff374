#pragma once
// The `dds:` section: how rumi-manager serves the map over Cyclone DDS
// (docs/dds.md), and the names every server and client derive from it.
// Cyclone runs without iceoryx: the shared-memory transport stays off and no
// RouDi is needed; the network interface is loopback unless configured.
#include <cstdint>
#include <string>

#include "common/option_spec.h"

namespace rumi {

struct DdsOptions {
  bool enabled = false;       // configs/daemon.yaml turns it on for rumid
  int domain_id = 0;
  std::string interface = "lo";  // a network interface name or address; "" = Cyclone's choice
  // Topics are <topic_prefix>/<name>; "" = rumi/<instance>.
  std::string topic_prefix;
  bool ros2_compat = false;   // also publish ROS 2 shaped topics (rt/...)
  int max_page_points = 200000;   // a points page never holds more
  // A reply sample stays below this (<= 4 MiB). Smaller samples pipeline:
  // 100k points (1.2 MB) took 4-5 ms in 128-256 KiB chunks, 20 ms in one
  // (rumi-dds-bench --chunk-bytes, docs/dds.md).
  int64_t chunk_bytes = 256 << 10;
  double reply_block_s = 0.1;     // a write to a slow client waits at most this long
  static const OptionSpec<DdsOptions>& Spec();  // section `dds:`
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
};

// The topic names of one instance.
struct DdsTopics {
  std::string prefix;  // rumi/<instance> or the configured prefix
  std::string status, pose, events, request, reply;
  // ROS 2 names (rt/<ros prefix>/...): the prefix with '-' as '_' (ROS
  // names allow only [A-Za-z0-9_/]).
  std::string ros_map, ros_path, ros_points, ros_pose;
};
DdsTopics TopicsFor(const DdsOptions& o, const std::string& instance);

// Cyclone's configuration for the domain: the interface, shared memory off,
// no tracing. XML, as dds_create_domain takes it.
std::string DomainConfigXml(const DdsOptions& o);

}  // namespace rumi
