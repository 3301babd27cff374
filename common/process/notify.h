#pragma once
// The systemd notify protocol (sd_notify), used both ways:
//  - Notifier, in every rumi process: READY=1, STATUS=<line>, WATCHDOG=1,
//    STOPPING=1 through libsystemd's sd_notify to $NOTIFY_SOCKET (a no-op
//    without it), plus RUMI_STATUS=<one-line JSON>, a field systemd ignores,
//    that carries a child's status to rumid.
//  - NotifyServer, in rumid and `rumi eval run`: the datagram socket whose
//    address the children get as $NOTIFY_SOCKET; each message comes with the
//    sender's pid (SO_PASSCRED), as systemd receives them.
#include <sys/types.h>

#include <chrono>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace rumi {

class Notifier {
 public:
  // min_interval_s: Heartbeat sends at most this often.
  explicit Notifier(double min_interval_s = 0.5);
  bool active() const { return active_; }  // $NOTIFY_SOCKET is set
  void Ready() { Send("READY=1"); }
  void Stopping() { Send("STOPPING=1"); }
  void Status(const std::string& line) { Send("STATUS=" + line); }
  // The loop turns: WATCHDOG=1 and RUMI_STATUS=<status>, rate-limited
  // unless `force`. Returns whether it sent.
  bool Heartbeat(const nlohmann::json& status, bool force = false);
  // Raw fields, "A=1\nB=2".
  void Send(const std::string& fields);

 private:
  bool active_ = false;
  double min_interval_s_;
  std::chrono::steady_clock::time_point last_{};
};

// "READY=1\nSTATUS=x" -> {READY: 1, STATUS: x}.
std::map<std::string, std::string> ParseNotifyFields(const std::string& payload);

class NotifyServer {
 public:
  // Binds an abstract unix datagram socket "@<name>" (no file to clean up).
  // Throws std::runtime_error naming the errno.
  explicit NotifyServer(const std::string& name);
  ~NotifyServer();
  NotifyServer(const NotifyServer&) = delete;
  NotifyServer& operator=(const NotifyServer&) = delete;

  const std::string& address() const { return address_; }  // the value for $NOTIFY_SOCKET
  struct Message {
    pid_t pid = 0;  // sender (0 when the kernel gave no credentials)
    std::map<std::string, std::string> fields;
  };
  // Every datagram waiting, without blocking; waits up to timeout_s for the
  // first when there is none.
  std::vector<Message> Receive(double timeout_s = 0.0);

 private:
  int fd_ = -1;
  std::string address_;
};

}  // namespace rumi
