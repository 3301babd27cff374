#pragma once
// The ground station's end of the robot link (config `source.link:`, read when
// source.kind is link; docs/robot_link.md).
#include <string>

#include "common/option_spec.h"
#include "ipc/link/rate_control.h"

namespace rumi {

struct LinkOptions {
  std::string bind = "0.0.0.0:5600";  // UDP address the robot sends to (port 0: any, tests)
  std::string robot;                  // robot's "ip:port"; "": learned from its datagrams
  int robot_id = 1;
  double frame_deadline_ms = 500;     // an incomplete frame is dropped this long after it was due
  double nack_delay_ms = 60;          // first NACK this long after a frame's first fragment
  double nack_interval_ms = 100;      // then again every this long
  double heartbeat_ms = 500;          // ground heartbeat period (carries halt/resume)
  double silence_s = 3.0;             // nothing from the robot this long: status "waiting"
  double end_after_silence_s = 0;     // > 0: the stream ends (the session finishes) once a robot
                                      // that was heard is silent this long (evaluation runs)
  double control_retry_ms = 200;      // resend an unacknowledged control this often
  int control_retries = 25;           // then give up (logged); the heartbeat still carries halt
  double sync_interval_ms = 250;      // a clock round trip this often (10 at 100 ms first)
  int queue_frames = 8;               // complete frames waiting for the front; oldest dropped
  std::string frames_log;             // CSV of every frame (latency, fragments); "" none
  double max_halt_s = 15;             // hierarchical mode: resume even if the merge has not come
  std::string key_file;               // the robot's key (`rumi link keygen`), 0600
  bool insecure = false;              // true: no key, anyone on the network may steer the robot
  double halt_alarm_s = 2.0;          // the robot walks/stands against the station's wish this long: alarm
  RateControlOptions rate_control;    // a lower frame rate when the link cannot carry the frames
  // A key or an explicit insecure: what an endpoint needs (the source's spec
  // asks it of a link source; LinkEndpoint refuses to start without it).
  bool Keyed() const { return !key_file.empty() || insecure; }
  static const OptionSpec<LinkOptions>& Spec();
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
};

// "host:port" -> parts; false (and *why) when it is not one. host may be
// empty or "*" (any address).
bool ParseHostPort(const std::string& s, std::string* host, int* port, std::string* why);

}  // namespace rumi
