#include "ipc/link/robot_sim.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "ipc/link/link_endpoint.h"
#include "ipc/link/link_options.h"

namespace rumi {

Impairment::Impairment(const ImpairmentOptions& o, uint64_t seed) : o_(o), rng_(seed) {}

bool Impairment::Admit(size_t bytes, int64_t now_us, int64_t* deliver_us) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // Gilbert model: a burst ends with probability 1/burst; bursts start at a
  // rate that makes the long-run loss o_.loss.
  if (o_.loss > 0) {
    const double end = 1.0 / std::max(1.0, o_.burst);
    const double start = std::min(1.0, o_.loss * end / std::max(1e-9, 1.0 - o_.loss));
    in_burst_ = in_burst_ ? u(rng_) >= end : u(rng_) < start;
    if (in_burst_) return false;
  }
  int64_t t = now_us;
  if (o_.bandwidth_kbps > 0) {
    const int64_t tx = static_cast<int64_t>(bytes * 8.0 / o_.bandwidth_kbps * 1e3);
    free_at_us_ = std::max(free_at_us_, now_us) + tx;
    t = free_at_us_;
  }
  const double d = o_.latency_ms + (2 * u(rng_) - 1) * o_.jitter_ms;
  *deliver_us = t + static_cast<int64_t>(std::max(0.0, d) * 1000);
  return true;
}

SimRobot::SimRobot(const SimRobotOptions& o)
    : o_(o), robot_(std::make_unique<rr_robot>()), up_(o.up, o.seed), down_(o.down, o.seed * 7919 + 1) {
  std::string host, why;
  int p = 0;
  if (!ParseHostPort(o_.ground, &host, &p, &why)) throw std::runtime_error("robot-sim ground: " + why);
  sockaddr_in g{};
  g.sin_family = AF_INET;
  g.sin_port = htons(static_cast<uint16_t>(p));
  if (inet_pton(AF_INET, host.empty() ? "127.0.0.1" : host.c_str(), &g.sin_addr) != 1)
    throw std::runtime_error("robot-sim: ground address '" + o_.ground + "' is not an IPv4 address");
  std::memcpy(ground_addr_, &g, sizeof(g));
  ground_addr_len_ = sizeof(g);
  sockaddr_in b{};
  b.sin_family = AF_INET;
  const size_t colon = o_.bind.rfind(':');
  b.sin_port = htons(static_cast<uint16_t>(colon == std::string::npos ? 0 : std::atoi(o_.bind.c_str() + colon + 1)));
  const std::string bh = colon == std::string::npos ? o_.bind : o_.bind.substr(0, colon);
  if (inet_pton(AF_INET, bh.empty() ? "127.0.0.1" : bh.c_str(), &b.sin_addr) != 1)
    throw std::runtime_error("robot-sim: bind address '" + o_.bind + "' is not IPv4 host:port");
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0 || bind(fd_, reinterpret_cast<sockaddr*>(&b), sizeof(b)) != 0) {
    const std::string e = std::strerror(errno);
    if (fd_ >= 0) close(fd_);
    throw std::runtime_error("robot-sim: cannot bind " + o_.bind + ": " + e);
  }
  socklen_t bl = sizeof(b);
  getsockname(fd_, reinterpret_cast<sockaddr*>(&b), &bl);
  port_ = ntohs(b.sin_port);
  start_ground_us_ = LinkNowUs();
  rr_hw hw{this, HwSend, HwNow, HwMotion, HwCamera, HwRssi, HwRandom};
  rr_config c;
  rr_config_default(&c);
  c.robot_id = static_cast<uint16_t>(o_.robot_id);
  c.has_key = o_.has_key;
  std::memcpy(c.key, o_.key.data(), sizeof(c.key));
  c.failsafe_ms = static_cast<uint32_t>(o_.failsafe_ms);
  std::lock_guard<std::mutex> l(mu_);
  rr_init(robot_.get(), &hw, &c);
  thread_ = std::thread([this] { Run(); });
}

SimRobot::~SimRobot() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) close(fd_);
}

int64_t SimRobot::RobotClockAt(int64_t ground_us) const {
  const double since = static_cast<double>(ground_us - start_ground_us_);
  // An arbitrary epoch of the robot's own (boot time), plus offset and drift.
  return 1000000000LL + static_cast<int64_t>(std::llround(since * (1.0 + o_.drift_ppm * 1e-6) + o_.clock_offset_ms * 1e3));
}

int64_t SimRobot::RobotNowUs() const { return RobotClockAt(LinkNowUs()); }

// Called with mu_ held (from inside rr_* calls).
int SimRobot::HwSend(void* ctx, const uint8_t* data, size_t len) {
  auto* s = static_cast<SimRobot*>(ctx);
  int64_t at = 0;
  if (!s->up_.Admit(len, LinkNowUs(), &at)) {
    ++s->up_lost_;
    return 0;  // sent; the air lost it
  }
  s->up_q_.emplace(at, std::vector<uint8_t>(data, data + len));
  return 0;
}
uint64_t SimRobot::HwNow(void* ctx) { return static_cast<uint64_t>(static_cast<SimRobot*>(ctx)->RobotNowUs()); }
void SimRobot::HwMotion(void* ctx, int moving, int) {
  auto* s = static_cast<SimRobot*>(ctx);
  s->motion_.push_back({LinkNowUs(), moving != 0});
}
int SimRobot::HwCamera(void* ctx, int, int, int, int fps_milli) {
  static_cast<SimRobot*>(ctx)->asked_fps_milli_ = fps_milli;  // the size and quality are the sequence's
  return 0;
}
int SimRobot::HwRssi(void* ctx) { return static_cast<SimRobot*>(ctx)->o_.rssi_dbm; }

int SimRobot::HwRandom(void*, uint8_t* out, size_t n) { return RandomBytes(out, n) ? 0 : -1; }

int64_t SimRobot::SendFrame(const std::vector<uint8_t>& bytes, int width, int height, uint8_t format,
                            uint8_t quality) {
  std::lock_guard<std::mutex> l(mu_);
  return rr_send_frame(robot_.get(), bytes.data(), bytes.size(), static_cast<uint16_t>(width),
                       static_cast<uint16_t>(height), format, quality, static_cast<uint64_t>(RobotNowUs()));
}

void SimRobot::AddImu(const float accel[3], const float gyro[3]) {
  rl_imu_sample s;
  s.t_us = static_cast<uint64_t>(RobotNowUs());
  std::copy(accel, accel + 3, s.accel);
  std::copy(gyro, gyro + 3, s.gyro);
  std::lock_guard<std::mutex> l(mu_);
  rr_add_imu(robot_.get(), &s);
}

bool SimRobot::moving() const {
  std::lock_guard<std::mutex> l(mu_);
  return rr_moving(robot_.get());
}

bool SimRobot::heard() const {
  std::lock_guard<std::mutex> l(mu_);
  return robot_->heard != 0;
}

bool SimRobot::authenticated() const {
  std::lock_guard<std::mutex> l(mu_);
  return rr_authenticated(robot_.get()) != 0;
}

rr_stats SimRobot::stats() const {
  std::lock_guard<std::mutex> l(mu_);
  return robot_->stats;
}

std::vector<std::pair<int64_t, bool>> SimRobot::motion_log() const {
  std::lock_guard<std::mutex> l(mu_);
  return motion_;
}

void SimRobot::Run() {
  std::vector<uint8_t> buf(65536);
  while (!stop_) {
    pollfd p{fd_, POLLIN, 0};
    poll(&p, 1, 1);
    const int64_t now = LinkNowUs();
    std::vector<std::vector<uint8_t>> to_ground, to_robot;
    {
      std::lock_guard<std::mutex> l(mu_);
      for (int k = 0; k < 256; ++k) {
        const ssize_t n = recv(fd_, buf.data(), buf.size(), MSG_DONTWAIT);
        if (n < 0) break;
        int64_t at = 0;
        if (down_.Admit(static_cast<size_t>(n), now, &at)) {
          down_q_.emplace(at, std::vector<uint8_t>(buf.begin(), buf.begin() + n));
        } else {
          ++down_lost_;
        }
      }
      while (!down_q_.empty() && down_q_.begin()->first <= now) {
        rr_on_datagram(robot_.get(), down_q_.begin()->second.data(), down_q_.begin()->second.size());
        down_q_.erase(down_q_.begin());
      }
      rr_poll(robot_.get());
      while (!up_q_.empty() && up_q_.begin()->first <= now) {
        to_ground.push_back(std::move(up_q_.begin()->second));
        up_q_.erase(up_q_.begin());
      }
    }
    for (auto& d : to_ground)
      sendto(fd_, d.data(), d.size(), 0, reinterpret_cast<sockaddr*>(ground_addr_), ground_addr_len_);
  }
}

}  // namespace rumi
