#pragma once
// A simulated robot on the far side of a bad Wi-Fi link: the firmware's own
// link logic (firmware/robot, rr_robot) over real UDP on this host, with the
// network's faults applied in both directions (loss, bursts, latency,
// jitter, a bandwidth cap) and a robot clock of its own (offset, drift).
// `rumi robot-sim` feeds it a sequence; the tests feed it bytes.
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "ipc/link/link_key.h"
#include "rumi_robot.h"

namespace rumi {

struct ImpairmentOptions {
  double loss = 0;            // probability a datagram is lost (long-run average)
  double burst = 1;           // mean length of a run of lost datagrams (1: independent losses)
  double latency_ms = 0;      // one-way delay
  double jitter_ms = 0;       // +- uniform around latency (reorders datagrams)
  double bandwidth_kbps = 0;  // 0: unlimited; else datagrams queue behind each other
};

// What happens to each datagram on one direction of the link.
class Impairment {
 public:
  Impairment(const ImpairmentOptions& o, uint64_t seed);
  // False: lost. Else *deliver_us is when it arrives.
  bool Admit(size_t bytes, int64_t now_us, int64_t* deliver_us);

 private:
  ImpairmentOptions o_;
  std::mt19937_64 rng_;
  bool in_burst_ = false;
  int64_t free_at_us_ = 0;
};

struct SimRobotOptions {
  std::string ground = "127.0.0.1:5600";  // where the ground station listens
  std::string bind = "127.0.0.1:0";       // the robot's own address (port 0: any)
  int robot_id = 1;
  ImpairmentOptions up;                   // robot -> ground
  ImpairmentOptions down;                 // ground -> robot
  double clock_offset_ms = 0;             // robot clock minus ground clock at start
  double drift_ppm = 0;                   // robot clock runs fast by this much
  double failsafe_ms = 2000;
  int rssi_dbm = -55;                     // what its heartbeats report (0: unknown)
  bool has_key = false;                   // authenticated link with key; false: insecure
  LinkKey key{};
  uint64_t seed = 1;
};

class SimRobot {
 public:
  explicit SimRobot(const SimRobotOptions& o);  // throws std::runtime_error (socket)
  ~SimRobot();

  // Sends an image captured now (robot clock). Returns its frame id, -1 if too large.
  int64_t SendFrame(const std::vector<uint8_t>& bytes, int width, int height, uint8_t format, uint8_t quality);
  void AddImu(const float accel[3], const float gyro[3]);
  bool moving() const;
  bool heard() const;  // the robot has heard the ground station since it started
  bool authenticated() const;  // with a key: a session with the ground station is up
  // The frame rate the ground station asked for (control `frame rate`), fps;
  // 0: none asked (the sequence's own). The caller paces its frames by it.
  double asked_fps() const { return asked_fps_milli_.load() * 1e-3; }
  int64_t RobotNowUs() const;          // the simulated robot clock
  int64_t RobotClockAt(int64_t ground_us) const;
  rr_stats stats() const;
  uint64_t up_lost() const { return up_lost_; }
  uint64_t down_lost() const { return down_lost_; }
  // (ground clock us, moving) at every change of the walking state.
  std::vector<std::pair<int64_t, bool>> motion_log() const;
  int port() const { return port_; }

 private:
  static int HwSend(void* ctx, const uint8_t* data, size_t len);
  static uint64_t HwNow(void* ctx);
  static void HwMotion(void* ctx, int moving, int gait);
  static int HwCamera(void* ctx, int w, int h, int q, int f);
  static int HwRssi(void* ctx);
  static int HwRandom(void* ctx, uint8_t* out, size_t n);
  void Run();

  SimRobotOptions o_;
  int fd_ = -1, port_ = 0;
  unsigned char ground_addr_[128] = {};
  unsigned ground_addr_len_ = 0;
  int64_t start_ground_us_ = 0;
  mutable std::mutex mu_;  // the robot and both queues
  std::unique_ptr<rr_robot> robot_;
  Impairment up_, down_;
  std::multimap<int64_t, std::vector<uint8_t>> up_q_, down_q_;
  std::atomic<uint64_t> up_lost_{0}, down_lost_{0};
  std::atomic<int> asked_fps_milli_{0};
  std::vector<std::pair<int64_t, bool>> motion_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace rumi
