#pragma once
// The ground station's end of the robot link: a UDP socket and a thread that
// reassembles frames (FrameReassembler, NACKs), keeps the robot's clock
// (ClockSync round trips), buffers IMU samples, sends heartbeats and
// controls (halt/resume with acknowledgement and retries; the frame rate the
// link can carry, RateControl) and counts everything for the status.
// docs/robot_link.md.
//
// Clocks: "ground" is the steady (monotonic) clock in microseconds; every
// frame and IMU sample is put on it through the clock sync.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/recent_samples.h"
#include "ipc/link/clock_sync.h"
#include "ipc/link/frame_reassembler.h"
#include "ipc/link/link_key.h"
#include "ipc/link/link_options.h"

namespace rumi {

struct LinkImuSample {
  int64_t ground_us = 0;
  float accel[3] = {0, 0, 0};
  float gyro[3] = {0, 0, 0};
};

struct LinkStats {
  ReassemblerStats frames;
  uint64_t datagrams = 0;
  uint64_t bad_datagrams = 0;         // failed to parse (garbage, truncated, corrupted)
  uint64_t other_robot = 0;           // another robot id
  // Authentication (docs/robot_link.md, "Security"): each costs a counter, no state.
  bool insecure = false;              // link.insecure: nothing is authenticated
  bool authenticated = false;         // a session with the robot is established
  uint64_t sessions = 0;              // sessions established (robot restarts, fail-safes)
  uint64_t unauthenticated = 0;       // no tag (a robot without key, or anyone else)
  uint64_t auth_failures = 0;         // a tag our keys did not make (spoofed or corrupted)
  uint64_t replays = 0;               // a sequence number seen before (or a jump)
  uint64_t wrong_source = 0;          // authentic, but not from the pinned address
  uint64_t hellos_dropped = 0;        // HELLOs beyond the answer rate
  // The robot walks while the station wants it halted, or stands while it
  // wants it walking, for link.halt_alarm_s or longer.
  bool halt_alarm = false;
  double halt_alarm_s = 0;            // how long the current disagreement has lasted
  uint64_t halt_alarms = 0;           // disagreements that raised the alarm
  uint64_t frames_delivered = 0;      // handed to the front
  uint64_t frames_overflow = 0;       // complete but the front was too slow: oldest dropped
  uint64_t imu_samples = 0;
  uint64_t imu_gaps = 0;              // a hole of more than 3 sample periods
  uint64_t controls_sent = 0, controls_acked = 0, controls_failed = 0;
  uint64_t send_failures = 0;
  double latency_p50_ms = 0, latency_p95_ms = 0, latency_max_ms = 0;  // capture -> complete
  double clock_offset_ms = 0, clock_drift_ppm = 0, clock_best_rtt_ms = 0;
  int clock_round_trips = 0;
  bool synced = false;
  bool robot_heard = false;
  double robot_silent_s = 0;
  bool robot_halted = false, robot_failsafe = false;  // as the robot last said
  bool want_halt = false;
  int robot_rssi = 0;
  double rate_asked_fps = 0;          // the frame rate asked of the robot (0: never: its own)
  int rate_cuts = 0, rate_raises = 0;
  nlohmann::json ToJson() const;
};

struct LinkFrameOut {
  LinkFrame frame;
  int64_t ground_capture_us = 0;  // capture time on the ground clock
};

class LinkEndpoint {
 public:
  // Binds the socket (throws std::runtime_error naming the address when it
  // cannot) and starts the thread.
  explicit LinkEndpoint(const LinkOptions& o);
  ~LinkEndpoint();
  LinkEndpoint(const LinkEndpoint&) = delete;
  LinkEndpoint& operator=(const LinkEndpoint&) = delete;

  // The next complete frame, in order; false after timeout_ms or once *stop.
  bool NextFrame(LinkFrameOut* out, int timeout_ms, const std::atomic<bool>* stop = nullptr);
  // IMU samples received so far (ground clock), removed from the buffer.
  std::vector<LinkImuSample> TakeImu();
  // Halt or resume the robot: a control with retries until acknowledged; the
  // heartbeat keeps saying it too. Idempotent.
  void SetHalt(bool halt);
  // A camera or gait command (rl_command), retried until acknowledged.
  void SendControl(uint8_t command, int32_t a0 = 0, int32_t a1 = 0, int32_t a2 = 0);
  // Acknowledged by the robot: it halted (true) / walks (false) as asked.
  bool HaltAcknowledged() const;
  LinkStats stats() const;
  int port() const { return port_; }

 private:
  struct PendingControl {
    rl_control c;
    uint32_t id = 0;
    int64_t last_sent_us = 0;
    int tries = 0;
  };
  void Run();
  void OnDatagram(const uint8_t* data, size_t len, int64_t now_us, const void* from, unsigned from_len);
  bool Authentic(const rl_message& m, const uint8_t* data, size_t len, const void* from, unsigned from_len);
  void OnHello(const rl_message& m, const uint8_t* data, size_t len, const void* from, unsigned from_len,
               int64_t now_us);
  void HaltAlarm(int64_t now_us);  // mu_ held
  void Timers(int64_t now_us);
  void QueueControl(uint8_t command, int32_t a0 = 0, int32_t a1 = 0, int32_t a2 = 0);  // mu_ held
  void Send(rl_message* m);
  // The datagram as it goes out: sequence number, robot id, tag.
  size_t Seal(rl_message* m, const uint8_t* key, uint8_t* out, size_t cap);
  void LogFrame(const LinkFrame& f, int64_t ground_capture_us, const char* status);

  LinkOptions o_;
  int fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;

  mutable std::mutex mu_;           // guards everything below the thread's locals
  std::condition_variable cv_;
  std::deque<LinkFrameOut> frames_;
  std::deque<LinkImuSample> imu_;
  LinkStats stats_;
  RecentSamples latencies_ms_{1000};  // the percentiles are over the newest 1000..2000
  bool want_halt_ = false;
  bool halt_acked_ = false;
  std::vector<PendingControl> controls_;

  // Thread-only.
  struct Session {
    LinkKey key{};
    uint8_t nonce_robot[RL_NONCE_SIZE] = {};
    uint8_t nonce_ground[RL_NONCE_SIZE] = {};
    rl_replay replay{};
    int64_t created_us = 0;
  };
  bool secure_ = false;
  LinkKey key_{};                   // the robot's key
  bool have_session_ = false;
  Session session_;
  std::vector<Session> pending_;    // answered HELLOs, newest last (at most 4)
  int64_t hello_second_us_ = 0;
  int hellos_this_second_ = 0;
  int64_t disagree_since_us_ = 0;
  FrameReassembler reassembler_;
  RateControl rate_;
  ClockSync clock_;
  bool have_robot_addr_ = false;
  unsigned char robot_addr_[128] = {};  // sockaddr_storage
  unsigned robot_addr_len_ = 0;
  uint32_t seq_ = 0, next_control_id_ = 1, next_sync_id_ = 1;
  int64_t last_heard_us_ = 0, last_heartbeat_us_ = 0, last_sync_us_ = 0, start_us_ = 0;
  int syncs_sent_ = 0;
  int64_t last_imu_us_ = 0;
  double imu_period_us_ = 0;
  std::ofstream frames_log_;
};

int64_t LinkNowUs();  // the ground clock (steady, microseconds)

}  // namespace rumi
