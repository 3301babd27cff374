#include "common/process/notify.h"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace rumi {

Notifier::Notifier(double min_interval_s) : min_interval_s_(min_interval_s) {
  const char* s = std::getenv("NOTIFY_SOCKET");
  active_ = s != nullptr && *s != '\0';
}

void Notifier::Send(const std::string& fields) {
  if (active_) sd_notify(0, fields.c_str());
}

bool Notifier::Heartbeat(const nlohmann::json& status, bool force) {
  if (!active_) return false;
  const auto now = std::chrono::steady_clock::now();
  if (!force && std::chrono::duration<double>(now - last_).count() < min_interval_s_) return false;
  last_ = now;
  Send("WATCHDOG=1\nRUMI_STATUS=" + status.dump());
  return true;
}

std::map<std::string, std::string> ParseNotifyFields(const std::string& payload) {
  std::map<std::string, std::string> fields;
  size_t start = 0;
  while (start < payload.size()) {
    size_t end = payload.find('\n', start);
    if (end == std::string::npos) end = payload.size();
    const std::string line = payload.substr(start, end - start);
    const size_t eq = line.find('=');
    if (eq != std::string::npos && eq > 0) fields[line.substr(0, eq)] = line.substr(eq + 1);
    start = end + 1;
  }
  return fields;
}

NotifyServer::NotifyServer(const std::string& name) {
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("notify socket: ") + std::strerror(errno));
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (name.size() + 1 >= sizeof(addr.sun_path)) {
    ::close(fd_);
    throw std::runtime_error("notify socket name too long: " + name);
  }
  // Abstract namespace: a leading NUL, written "@" in $NOTIFY_SOCKET.
  std::memcpy(addr.sun_path + 1, name.data(), name.size());
  const socklen_t len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size());
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), len) != 0) {
    const std::string e = std::strerror(errno);
    ::close(fd_);
    throw std::runtime_error("notify socket @" + name + ": " + e);
  }
  const int on = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_PASSCRED, &on, sizeof(on));
  // Room for a burst of status messages while rumid is busy.
  const int buf = 1 << 20;
  ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &buf, sizeof(buf));
  address_ = "@" + name;
}

NotifyServer::~NotifyServer() {
  if (fd_ >= 0) ::close(fd_);
}

std::vector<NotifyServer::Message> NotifyServer::Receive(double timeout_s) {
  std::vector<Message> out;
  if (timeout_s > 0) {
    pollfd p{fd_, POLLIN, 0};
    ::poll(&p, 1, static_cast<int>(timeout_s * 1000));
  }
  for (;;) {
    char data[65536];
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(ucred))];
    iovec iov{data, sizeof(data) - 1};
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof(control);
    const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT | MSG_CMSG_CLOEXEC);
    if (n < 0) {
      if (errno == EINTR) continue;
      break;  // EAGAIN: drained
    }
    Message m;
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_CREDENTIALS) {
        ucred cred{};
        std::memcpy(&cred, CMSG_DATA(c), sizeof(cred));
        m.pid = cred.pid;
      }
    }
    m.fields = ParseNotifyFields(std::string(data, static_cast<size_t>(n)));
    out.push_back(std::move(m));
  }
  return out;
}

}  // namespace rumi
