#include "ipc/dds/dds_options.h"

#include <algorithm>
#include <cctype>

namespace rumi {
namespace {

// Topic names end up in DDS and, with ros2_compat, in ROS: keep them plain.
std::string PrefixProblem(const std::string& p) {
  if (p.empty()) return "";
  if (p.size() > 100) return "longer than 100 characters";
  if (p.front() == '/' || p.back() == '/') return "must not start or end with '/'";
  for (char c : p)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '/')
      return std::string("'") + c + "' is not one of [A-Za-z0-9_/-]";
  if (p.find("//") != std::string::npos) return "holds an empty name ('//')";
  return "";
}

std::string InterfaceProblem(const std::string& s) {
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != ':' && c != '_' && c != '-')
      return std::string("'") + c + "' cannot be in an interface name or address";
  return "";
}

}  // namespace

const OptionSpec<DdsOptions>& DdsOptions::Spec() {
  using O = DdsOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("dds");
    s->Flag("enabled", &O::enabled, "rumi-manager serves the map over Cyclone DDS");
    s->Number("domain_id", &O::domain_id, AtLeast(0), AtMost(232), "DDS domain");
    s->Text("interface", &O::interface, "network interface or address (lo: nothing leaves the machine)",
            "[A-Za-z0-9.:_-]*", InterfaceProblem);
    s->Text("topic_prefix", &O::topic_prefix, "topics are <prefix>/<name>; empty: rumi/<instance>",
            "[A-Za-z0-9_/-]*", PrefixProblem);
    s->Flag("ros2_compat", &O::ros2_compat, "also publish ROS 2 shaped topics (rt/<prefix>/map, ...)");
    s->Number("max_page_points", &O::max_page_points, AtLeast(1), AtMost(10000000),
              "a points reply page holds at most this many");
    s->Number<int64_t>("chunk_bytes", &O::chunk_bytes, AtLeast<int64_t>(4096), AtMost<int64_t>(4ll << 20),
                       "a reply is split into samples below this size");
    s->Number("reply_block_s", &O::reply_block_s, AtLeast(0.0), AtMost(10.0),
              "a reply write to a slow client waits at most this long");
    return s;
  }();
  return *spec;
}

DdsTopics TopicsFor(const DdsOptions& o, const std::string& instance) {
  DdsTopics t;
  t.prefix = o.topic_prefix.empty() ? "rumi/" + instance : o.topic_prefix;
  t.status = t.prefix + "/status";
  t.pose = t.prefix + "/pose";
  t.events = t.prefix + "/events";
  t.request = t.prefix + "/request";
  t.reply = t.prefix + "/reply";
  std::string ros = t.prefix;
  std::replace(ros.begin(), ros.end(), '-', '_');
  t.ros_map = "rt/" + ros + "/map";
  t.ros_path = "rt/" + ros + "/path";
  t.ros_points = "rt/" + ros + "/points";
  t.ros_pose = "rt/" + ros + "/pose";
  return t;
}

std::string DomainConfigXml(const DdsOptions& o) {
  std::string x = "<CycloneDDS xmlns=\"https://cdds.io/config\"><Domain Id=\"any\"><General>";
  if (!o.interface.empty()) {
    // An address (192.168.1.5, fe80::1) or a name (lo, wlan0).
    const bool address = std::isdigit(static_cast<unsigned char>(o.interface[0])) ||
                         o.interface.find(':') != std::string::npos;
    x += "<Interfaces><NetworkInterface " + std::string(address ? "address" : "name") + "=\"" + o.interface +
         "\"/></Interfaces>";
  }
  x += "</General><SharedMemory><Enable>false</Enable></SharedMemory></Domain></CycloneDDS>";
  return x;
}

}  // namespace rumi
