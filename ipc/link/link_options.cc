#include "ipc/link/link_options.h"

#include "ipc/link/link_key.h"

namespace rumi {

bool ParseHostPort(const std::string& s, std::string* host, int* port, std::string* why) {
  const size_t colon = s.rfind(':');
  if (colon == std::string::npos) {
    if (why) *why = "'" + s + "' is not host:port";
    return false;
  }
  const std::string p = s.substr(colon + 1);
  int v = 0;
  for (char c : p) {
    if (c < '0' || c > '9' || v > 65535) {
      v = -1;
      break;
    }
    v = v * 10 + (c - '0');
  }
  if (p.empty() || v < 0 || v > 65535) {
    if (why) *why = "'" + s + "': port '" + p + "' is not 0..65535";
    return false;
  }
  *host = s.substr(0, colon);
  if (*host == "*") host->clear();
  *port = v;
  return true;
}

const OptionSpec<LinkOptions>& LinkOptions::Spec() {
  using O = LinkOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("link");
    s->Text("bind", &O::bind, "UDP host:port the robot sends to", true);
    s->Text("robot", &O::robot, "robot's host:port; '' learned from its first datagram");
    s->Number("robot_id", &O::robot_id, AtLeast(0), AtMost(65535), "robot id in every datagram");
    s->Number("frame_deadline_ms", &O::frame_deadline_ms, Above(0.0), AtMost(10000.0),
              "an incomplete frame is dropped this long after it was due");
    s->Number("nack_delay_ms", &O::nack_delay_ms, AtLeast(0.0), AtMost(10000.0),
              "first NACK this long after a frame's first fragment");
    s->Number("nack_interval_ms", &O::nack_interval_ms, Above(0.0), AtMost(10000.0), "NACK again every this long");
    s->Number("heartbeat_ms", &O::heartbeat_ms, Above(0.0), AtMost(60000.0), "ground heartbeat period");
    s->Number("silence_s", &O::silence_s, Above(0.0), AtMost(3600.0), "robot silent this long: status waiting");
    s->Number("end_after_silence_s", &O::end_after_silence_s, AtLeast(0.0), AtMost(86400.0),
              "> 0: end the stream once a robot that was heard is silent this long (evaluation runs)");
    s->Number("control_retry_ms", &O::control_retry_ms, Above(0.0), AtMost(60000.0),
              "resend an unacknowledged control this often");
    s->Number("control_retries", &O::control_retries, AtLeast(0), AtMost(10000), "then give up");
    s->Number("sync_interval_ms", &O::sync_interval_ms, Above(0.0), AtMost(60000.0), "clock round trip period");
    s->Number("queue_frames", &O::queue_frames, AtLeast(1), AtMost(1000), "complete frames waiting for the front");
    s->Text("frames_log", &O::frames_log, "CSV of every frame (latency, fragments); '' none");
    s->Number("max_halt_s", &O::max_halt_s, Above(0.0), AtMost(3600.0),
              "hierarchical mode: resume the robot after this long even if the merge has not come");
    s->Text("key_file", &O::key_file,
            "the robot's key, 64 hex digits, mode 0600 (`rumi link keygen`); every datagram authenticated");
    s->Flag("insecure", &O::insecure,
            "no key: unauthenticated lab link, anyone on the network can steer the robot (logged loudly)");
    s->Number("halt_alarm_s", &O::halt_alarm_s, Above(0.0), AtMost(3600.0),
              "alarm when the robot walks or stands against the station's wish this long");
    s->Section("rate_control", &O::rate_control, RateControlOptions::Spec());
    s->Rule([](const O& o) -> std::string {
      std::string h, why;
      int p;
      if (!ParseHostPort(o.bind, &h, &p, &why)) return "bind: " + why;
      if (!o.robot.empty() && !ParseHostPort(o.robot, &h, &p, &why)) return "robot: " + why;
      if (!o.robot.empty() && p == 0) return "robot: port 0 is not a robot's port";
      return "";
    });
    s->Rule("key_file and insecure: true exclude each other",
            [](const O& o) { return o.key_file.empty() || !o.insecure; });
    s->Rule([](const O& o) -> std::string {  // a key that cannot be used is a config error, found at start
      LinkKey key;
      std::string why;
      if (!o.key_file.empty() && !LoadLinkKey(o.key_file, &key, &why)) return "key_file: " + why;
      return "";
    });
    s->Rule("frame_deadline_ms must be > nack_delay_ms",
            [](const O& o) { return o.frame_deadline_ms > o.nack_delay_ms; });
    return s;
  }();
  return *spec;
}

}  // namespace rumi
