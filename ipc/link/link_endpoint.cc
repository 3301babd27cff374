#include "ipc/link/link_endpoint.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

namespace rumi {

int64_t LinkNowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

namespace {

bool Resolve(const std::string& hostport, sockaddr_storage* addr, socklen_t* len, std::string* why) {
  std::string host;
  int port = 0;
  if (!ParseHostPort(hostport, &host, &port, why)) return false;
  addrinfo hints{}, *res = nullptr;
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  const std::string p = std::to_string(port);
  const int rc = getaddrinfo(host.empty() ? nullptr : host.c_str(), p.c_str(), &hints, &res);
  if (rc != 0 || !res) {
    if (why) *why = "cannot resolve '" + hostport + "': " + gai_strerror(rc);
    return false;
  }
  std::memcpy(addr, res->ai_addr, res->ai_addrlen);
  *len = res->ai_addrlen;
  freeaddrinfo(res);
  return true;
}

std::string AddrText(const void* from) {
  const auto* a = static_cast<const sockaddr_in*>(from);
  char host[64] = "?";
  inet_ntop(AF_INET, &a->sin_addr, host, sizeof(host));
  return std::string(host) + ":" + std::to_string(ntohs(a->sin_port));
}

bool SameAddr(const void* a, unsigned alen, const void* b, unsigned blen) {
  const auto* x = static_cast<const sockaddr_in*>(a);
  const auto* y = static_cast<const sockaddr_in*>(b);
  return alen >= sizeof(sockaddr_in) && blen >= sizeof(sockaddr_in) && x->sin_family == y->sin_family &&
         x->sin_port == y->sin_port && x->sin_addr.s_addr == y->sin_addr.s_addr;
}


}  // namespace

nlohmann::json LinkStats::ToJson() const {
  return {
      {"robot_heard", robot_heard},
      {"robot_silent_s", robot_silent_s},
      {"robot_halted", robot_halted},
      {"robot_failsafe", robot_failsafe},
      {"want_halt", want_halt},
      {"robot_rssi_dbm", robot_rssi},
      {"frames_complete", frames.frames_complete},
      {"frames_delivered", frames_delivered},
      {"frames_dropped", frames.frames_dropped},
      {"frames_overflow", frames_overflow},
      {"frames_recovered", frames.frames_recovered},
      {"fragments", frames.fragments},
      {"fragments_recovered", frames.fragments_recovered},
      {"fragments_duplicate", frames.duplicates},
      {"fragments_late", frames.late},
      {"fragments_inconsistent", frames.inconsistent},
      {"nacks", frames.nacks},
      {"resyncs", frames.resyncs},
      {"out_of_window", frames.out_of_window},
      {"nacks_suppressed", frames.nacks_suppressed},
      {"datagrams", datagrams},
      {"bad_datagrams", bad_datagrams},
      {"other_robot", other_robot},
      {"auth",
       {{"insecure", insecure},
        {"authenticated", authenticated},
        {"sessions", sessions},
        {"unauthenticated", unauthenticated},
        {"failures", auth_failures},
        {"replays", replays},
        {"wrong_source", wrong_source},
        {"hellos_dropped", hellos_dropped}}},
      {"halt_alarm", halt_alarm},
      {"halt_alarm_s", halt_alarm_s},
      {"halt_alarms", halt_alarms},
      {"imu_samples", imu_samples},
      {"imu_gaps", imu_gaps},
      {"controls_sent", controls_sent},
      {"controls_acked", controls_acked},
      {"controls_failed", controls_failed},
      {"send_failures", send_failures},
      {"latency_ms", {{"p50", latency_p50_ms}, {"p95", latency_p95_ms}, {"max", latency_max_ms}}},
      {"clock",
       {{"synced", synced},
        {"offset_ms", clock_offset_ms},
        {"drift_ppm", clock_drift_ppm},
        {"best_round_trip_ms", clock_best_rtt_ms},
        {"round_trips", clock_round_trips}}},
      {"rate_control", {{"asked_fps", rate_asked_fps}, {"cuts", rate_cuts}, {"raises", rate_raises}}},
  };
}

LinkEndpoint::LinkEndpoint(const LinkOptions& o)
    : o_(o),
      reassembler_(FrameReassemblerOptions{static_cast<int64_t>(o.frame_deadline_ms * 1000),
                                           static_cast<int64_t>(o.nack_delay_ms * 1000),
                                           static_cast<int64_t>(o.nack_interval_ms * 1000), 64}),
      rate_(o.rate_control, o.frame_deadline_ms) {
  std::string why;
  if (!o_.Check(&why)) throw std::runtime_error("link options: " + why);
  if (!o_.Keyed())
    throw std::runtime_error(
        "link: set key_file (a key from `rumi link keygen`) or, for an unauthenticated lab link, insecure: true");
  if (!o_.key_file.empty()) {
    if (!LoadLinkKey(o_.key_file, &key_, &why)) throw std::runtime_error("link.key_file: " + why);
    secure_ = true;
  } else {
    spdlog::warn("link: INSECURE (link.insecure: true): datagrams are not authenticated; anyone on the "
                 "network can halt, steer or impersonate the robot. Make a key with `rumi link keygen`.");
  }
  stats_.insecure = !secure_;
  sockaddr_storage addr{};
  socklen_t len = 0;
  if (!Resolve(o_.bind, &addr, &len, &why)) throw std::runtime_error("link.bind: " + why);
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("link: socket: ") + std::strerror(errno));
  const int one = 1;
  setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  const int rcvbuf = 4 << 20;  // a burst of frames while the thread is descheduled
  setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
  if (bind(fd_, reinterpret_cast<sockaddr*>(&addr), len) != 0) {
    const std::string e = std::strerror(errno);
    close(fd_);
    throw std::runtime_error("link: cannot bind UDP " + o_.bind + ": " + e);
  }
  sockaddr_in bound{};
  socklen_t blen = sizeof(bound);
  getsockname(fd_, reinterpret_cast<sockaddr*>(&bound), &blen);
  port_ = ntohs(bound.sin_port);
  if (!o_.robot.empty()) {
    sockaddr_storage r{};
    socklen_t rl = 0;
    if (!Resolve(o_.robot, &r, &rl, &why)) {
      close(fd_);
      throw std::runtime_error("link.robot: " + why);
    }
    std::memcpy(robot_addr_, &r, rl);
    robot_addr_len_ = rl;
    have_robot_addr_ = true;
  }
  if (!o_.frames_log.empty()) {
    frames_log_.open(o_.frames_log, std::ios::out | std::ios::trunc);
    if (!frames_log_) spdlog::warn("link: cannot write the frames log {}", o_.frames_log);
    frames_log_ << "frame_id,robot_us,ground_capture_us,first_us,complete_us,latency_ms,fragments,recovered,status\n";
  }
  // Sequence numbers and control ids continue across ground-station restarts
  // (the robot orders halt/resume by them): start from the wall clock in ms.
  const auto wall_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                           std::chrono::system_clock::now().time_since_epoch())
                           .count();
  seq_ = static_cast<uint32_t>(wall_ms);
  next_control_id_ = static_cast<uint32_t>(wall_ms) | 1u;
  start_us_ = LinkNowUs();
  thread_ = std::thread([this] { Run(); });
}

LinkEndpoint::~LinkEndpoint() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) close(fd_);
}

void LinkEndpoint::Run() {
  std::vector<uint8_t> buf(65536);
  while (!stop_) {
    pollfd p{fd_, POLLIN, 0};
    const int rc = poll(&p, 1, 5);
    const int64_t now = LinkNowUs();
    if (rc > 0 && (p.revents & POLLIN)) {
      for (int k = 0; k < 256; ++k) {  // drain what is there, bounded
        sockaddr_storage from{};
        socklen_t flen = sizeof(from);
        const ssize_t n =
            recvfrom(fd_, buf.data(), buf.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from), &flen);
        if (n < 0) break;
        if (!secure_ && !have_robot_addr_ && o_.robot.empty()) {
          rl_message m;
          if (rl_parse(buf.data(), static_cast<size_t>(n), &m) == RL_OK && m.h.robot_id == o_.robot_id) {
            std::memcpy(robot_addr_, &from, flen);
            robot_addr_len_ = flen;
            have_robot_addr_ = true;
            {
              std::lock_guard<std::mutex> l(mu_);
              last_heartbeat_us_ = 0;  // greet it now: a robot stands until it hears the station
            }
            spdlog::info("link: robot {} at {}", o_.robot_id, AddrText(&from));
          }
        }
        OnDatagram(buf.data(), static_cast<size_t>(n), LinkNowUs(), &from, flen);
      }
    }
    Timers(now);
  }
}

size_t LinkEndpoint::Seal(rl_message* m, const uint8_t* key, uint8_t* out, size_t cap) {
  m->h.robot_id = static_cast<uint16_t>(o_.robot_id);
  m->h.seq = seq_++;
  if (!m->h.time_us) m->h.time_us = static_cast<uint64_t>(LinkNowUs());
  if (key) m->h.flags |= RL_FLAG_AUTH;
  const size_t n = rl_encode(m, out, cap);
  return n && key ? rl_seal(key, out, n, cap) : n;
}

void LinkEndpoint::Send(rl_message* m) {
  // Authenticated: nothing goes out before a session (the robot would not
  // listen), and only to the address that session was made from.
  if (!have_robot_addr_ || (secure_ && !have_session_)) return;
  uint8_t out[RL_MAX_DATAGRAM];
  const size_t n = Seal(m, secure_ ? session_.key.data() : nullptr, out, sizeof(out));
  if (n == 0 || sendto(fd_, out, n, 0, reinterpret_cast<sockaddr*>(robot_addr_), robot_addr_len_) < 0) {
    std::lock_guard<std::mutex> l(mu_);
    ++stats_.send_failures;
  }
}

static rl_message Blank(uint8_t type, uint32_t id) {
  rl_message m;
  std::memset(&m, 0, sizeof(m));
  m.h.type = type;
  m.h.msg_id = id;
  m.h.frag_count = 1;
  return m;
}


// A robot asks for a session: answer with a nonce of ours under its key. The
// answer proves nothing to us yet (a HELLO can be replayed); the session
// counts only once a datagram under the derived key comes back. Answers are
// rate-limited and the pending sessions few, so HELLOs cost no more than that.
void LinkEndpoint::OnHello(const rl_message& m, const uint8_t* data, size_t len, const void* from,
                           unsigned from_len, int64_t now) {
  if (m.u.hello.role != RL_ROLE_ROBOT) {
    ++stats_.unauthenticated;
    return;
  }
  if (!rl_verify(key_.data(), data, len, &m)) {
    if (stats_.auth_failures++ % 1000 == 0)
      spdlog::warn("link: HELLO from {} with a wrong tag: not our robot's key ({} failures so far)",
                   AddrText(from), stats_.auth_failures);
    return;
  }
  if (now - hello_second_us_ >= 1000000) hello_second_us_ = now, hellos_this_second_ = 0;
  if (++hellos_this_second_ > 20) {
    ++stats_.hellos_dropped;
    return;
  }
  const Session* s = nullptr;
  if (have_session_ && std::memcmp(session_.nonce_robot, m.u.hello.nonce_robot, RL_NONCE_SIZE) == 0) s = &session_;
  for (const Session& p : pending_)
    if (std::memcmp(p.nonce_robot, m.u.hello.nonce_robot, RL_NONCE_SIZE) == 0) s = &p;
  if (!s) {
    Session p;
    std::memcpy(p.nonce_robot, m.u.hello.nonce_robot, RL_NONCE_SIZE);
    if (!RandomBytes(p.nonce_ground, RL_NONCE_SIZE) ||
        rl_session_key(key_.data(), p.nonce_robot, p.nonce_ground, p.key.data()) != 0) {
      spdlog::error("link: no random bytes for a session nonce");
      return;
    }
    p.created_us = now;
    if (pending_.size() >= 4) pending_.erase(pending_.begin());
    pending_.push_back(p);
    s = &pending_.back();
  }
  rl_message a = Blank(RL_HELLO, 0);
  a.u.hello.role = RL_ROLE_GROUND;
  std::memcpy(a.u.hello.nonce_robot, s->nonce_robot, RL_NONCE_SIZE);
  std::memcpy(a.u.hello.nonce_ground, s->nonce_ground, RL_NONCE_SIZE);
  uint8_t out[RL_MAX_DATAGRAM];
  const size_t n = Seal(&a, key_.data(), out, sizeof(out));
  if (n == 0 || sendto(fd_, out, n, 0, static_cast<const sockaddr*>(from), from_len) < 0) ++stats_.send_failures;
}

// Whether a parsed datagram is the session's robot's, new, and from its
// address; the first one under a pending session's key makes that session
// current and pins the robot's address.
bool LinkEndpoint::Authentic(const rl_message& m, const uint8_t* data, size_t len, const void* from,
                             unsigned from_len) {
  Session* s = nullptr;
  if (have_session_ && rl_verify(session_.key.data(), data, len, &m)) {
    if (!SameAddr(from, from_len, robot_addr_, robot_addr_len_)) {
      ++stats_.wrong_source;
      return false;
    }
    s = &session_;
  } else {
    for (auto it = pending_.begin(); it != pending_.end(); ++it) {
      if (!rl_verify(it->key.data(), data, len, &m)) continue;
      if (!o_.robot.empty() && !SameAddr(from, from_len, robot_addr_, robot_addr_len_)) {
        ++stats_.wrong_source;  // link.robot fixes the robot's address
        return false;
      }
      session_ = *it;
      pending_.erase(it);
      s = &session_;
      have_session_ = true;
      std::memcpy(robot_addr_, from, from_len);
      robot_addr_len_ = from_len;
      have_robot_addr_ = true;
      ++stats_.sessions;
      stats_.authenticated = true;
      last_heartbeat_us_ = 0;  // say what we want of it now
      spdlog::info("link: robot {} authenticated at {} (session {})", o_.robot_id, AddrText(from),
                   stats_.sessions);
      break;
    }
  }
  if (!s) {
    if (stats_.auth_failures++ % 1000 == 0)
      spdlog::warn("link: datagram from {} with a wrong tag: spoofed, corrupted or an old session ({} so far)",
                   AddrText(from), stats_.auth_failures);
    return false;
  }
  if (rl_replay_accept(&s->replay, m.h.seq) != RL_REPLAY_OK) {
    ++stats_.replays;
    return false;
  }
  return true;
}

void LinkEndpoint::OnDatagram(const uint8_t* data, size_t len, int64_t now, const void* from, unsigned from_len) {
  rl_message m;
  const int rc = rl_parse(data, len, &m);
  std::unique_lock<std::mutex> l(mu_);
  ++stats_.datagrams;
  if (rc != RL_OK) {
    if (stats_.bad_datagrams++ % 1000 == 0)
      spdlog::warn("link: bad datagram ({} bytes): {} ({} so far)", len, rl_error_string(rc), stats_.bad_datagrams);
    return;
  }
  if (m.h.robot_id != o_.robot_id) {
    ++stats_.other_robot;
    return;
  }
  if (secure_) {
    if (!m.tag) {
      if (stats_.unauthenticated++ % 1000 == 0)
        spdlog::warn("link: unauthenticated {} from {}: the robot has no key, or someone else is sending "
                     "({} so far; link.key_file)", rl_type_name(m.h.type), AddrText(from), stats_.unauthenticated);
      return;
    }
    if (m.h.type == RL_HELLO) {
      OnHello(m, data, len, from, from_len, now);
      return;
    }
    if (!Authentic(m, data, len, from, from_len)) return;
  } else if (m.h.type == RL_HELLO) {
    if (stats_.unauthenticated++ % 1000 == 0)
      spdlog::warn("link: the robot asks for an authenticated session but link.insecure is set: give the "
                   "ground station its key (link.key_file)");
    return;
  }
  last_heard_us_ = now;
  stats_.robot_heard = true;
  switch (m.h.type) {
    case RL_FRAME:
      reassembler_.Add(m, now);
      break;
    case RL_IMU:
      for (int i = 0; i < m.u.imu.count; ++i) {
        const rl_imu_sample& s = m.u.imu.sample[i];
        LinkImuSample x;
        x.ground_us = clock_.ToGround(static_cast<int64_t>(s.t_us));
        std::copy(s.accel, s.accel + 3, x.accel);
        std::copy(s.gyro, s.gyro + 3, x.gyro);
        // Gaps: compare with a slowly learned sample period.
        if (last_imu_us_) {
          const double dt = static_cast<double>(static_cast<int64_t>(s.t_us) - last_imu_us_);
          if (dt > 0) {
            if (imu_period_us_ > 0 && dt > 3 * imu_period_us_) ++stats_.imu_gaps;
            imu_period_us_ = imu_period_us_ > 0 ? 0.99 * imu_period_us_ + 0.01 * std::min(dt, 1e6) : dt;
          }
        }
        last_imu_us_ = static_cast<int64_t>(s.t_us);
        imu_.push_back(x);
        ++stats_.imu_samples;
      }
      while (imu_.size() > 20000) imu_.pop_front();  // a front that stopped reading: keep a minute at 300 Hz
      break;
    case RL_ACK:
      for (auto it = controls_.begin(); it != controls_.end(); ++it) {
        if (it->id != m.h.msg_id) continue;
        ++stats_.controls_acked;
        if (it->c.command == RL_CMD_HALT || it->c.command == RL_CMD_RESUME)
          halt_acked_ = (it->c.command == RL_CMD_HALT) == want_halt_;
        if (m.u.ack.result != RL_ACK_OK)
          spdlog::warn("link: robot refused control {} (result {})", it->c.command, m.u.ack.result);
        controls_.erase(it);
        break;
      }
      stats_.robot_halted = m.u.ack.halted;
      break;
    case RL_HEARTBEAT:
      if (m.u.heartbeat.role == RL_ROLE_ROBOT) {
        stats_.robot_halted = m.u.heartbeat.halted;
        stats_.robot_failsafe = m.u.heartbeat.failsafe;
        stats_.robot_rssi = m.u.heartbeat.rssi;
      }
      break;
    case RL_TIME_RESP:
      clock_.Add(static_cast<int64_t>(m.u.time.t1), static_cast<int64_t>(m.u.time.t2),
                 static_cast<int64_t>(m.u.time.t3), now);
      break;
    default:
      break;  // ground-bound types only
  }
}

void LinkEndpoint::LogFrame(const LinkFrame& f, int64_t cap, const char* status) {
  if (!frames_log_.is_open()) return;
  frames_log_ << f.frame_id << ',' << f.robot_time_us << ',' << cap << ',' << f.first_us << ',' << f.complete_us
              << ',' << (f.complete_us ? (f.complete_us - cap) * 1e-3 : 0.0) << ',' << f.fragments << ','
              << f.recovered << ',' << status << '\n';
}

void LinkEndpoint::Timers(int64_t now) {
  std::vector<NackRequest> nacks;
  std::vector<LinkFrame> done;
  std::vector<rl_message> out;
  {
    std::lock_guard<std::mutex> l(mu_);
    std::vector<uint32_t> dropped;
    done = reassembler_.Poll(now, &nacks, &dropped);
    for (uint32_t id : dropped) {
      LinkFrame lost;
      lost.frame_id = id;
      LogFrame(lost, 0, "dropped");
      rate_.OnFrame(now, false, 0);
    }
    for (LinkFrame& f : done) {
      LinkFrameOut o;
      o.ground_capture_us = clock_.synced() ? clock_.ToGround(static_cast<int64_t>(f.robot_time_us)) : f.first_us;
      const double lat = (f.complete_us - o.ground_capture_us) * 1e-3;
      latencies_ms_.Add(lat);
      rate_.OnFrame(now, true, lat);
      stats_.latency_max_ms = latencies_ms_.max();
      LogFrame(f, o.ground_capture_us, "complete");
      o.frame = std::move(f);
      frames_.push_back(std::move(o));
      if (static_cast<int>(frames_.size()) > o_.queue_frames) {
        frames_.pop_front();
        ++stats_.frames_overflow;
      }
    }
    if (!done.empty()) cv_.notify_all();
    HaltAlarm(now);
    if (const double fps = rate_.Poll(now); fps > 0) {
      QueueControl(RL_CMD_FRAME_RATE, static_cast<int32_t>(std::lround(fps * 1000)));
      stats_.rate_asked_fps = fps;
      stats_.rate_cuts = rate_.cuts();
      stats_.rate_raises = rate_.raises();
      spdlog::info("link: asking the robot for {:.1f} fps ({} after {} cuts, {} raises; most seen {:.1f} fps)", fps,
                   rate_.cuts() + rate_.raises() == 1 ? "first change" : "change", rate_.cuts(), rate_.raises(),
                   rate_.max_seen_fps());
    }
    // Controls: resend until acknowledged, then give up loudly.
    for (auto it = controls_.begin(); it != controls_.end();) {
      if (it->last_sent_us && now - it->last_sent_us < o_.control_retry_ms * 1000) {
        ++it;
        continue;
      }
      if (it->tries > o_.control_retries) {
        ++stats_.controls_failed;
        spdlog::warn("link: control {} not acknowledged after {} tries (the heartbeat still carries halt={})",
                     it->c.command, it->tries, want_halt_);
        it = controls_.erase(it);
        continue;
      }
      rl_message m = Blank(RL_CONTROL, it->id);
      m.u.control = it->c;
      out.push_back(m);
      it->last_sent_us = now;
      ++it->tries;
      ++stats_.controls_sent;
      ++it;
    }
    if (now - last_heartbeat_us_ >= o_.heartbeat_ms * 1000) {
      rl_message m = Blank(RL_HEARTBEAT, 0);
      m.u.heartbeat.role = RL_ROLE_GROUND;
      m.u.heartbeat.halted = want_halt_;
      m.u.heartbeat.frames_sent = static_cast<uint32_t>(stats_.frames_delivered);
      out.push_back(m);
      last_heartbeat_us_ = now;
    }
    const double sync_us = (syncs_sent_ < 10 ? 100 : o_.sync_interval_ms) * 1000;
    if (have_robot_addr_ && now - last_sync_us_ >= sync_us) {
      rl_message m = Blank(RL_TIME_REQ, next_sync_id_++);
      m.u.time.t1 = static_cast<uint64_t>(now);
      m.h.time_us = m.u.time.t1;
      out.push_back(m);
      last_sync_us_ = now;
      ++syncs_sent_;
    }
  }
  for (const NackRequest& r : nacks) {
    rl_message m = Blank(RL_NACK, r.frame_id);
    m.u.nack.count = static_cast<uint16_t>(r.missing.size());
    std::copy(r.missing.begin(), r.missing.end(), m.u.nack.index);
    out.push_back(m);
  }
  for (rl_message& m : out) {
    if (m.h.type == RL_TIME_REQ) {  // t1 as late as possible: the send itself
      m.u.time.t1 = m.h.time_us = static_cast<uint64_t>(LinkNowUs());
    }
    Send(&m);
  }
}

// The robot's own word (heartbeat, ack) against what the station wants: a
// robot that walks while a merge needs it halted (or a spoofed command that
// got through on an insecure link) must not pass silently.
void LinkEndpoint::HaltAlarm(int64_t now) {
  const bool silent = !last_heard_us_ || now - last_heard_us_ > static_cast<int64_t>(o_.silence_s * 1e6);
  const bool disagree = !silent && stats_.robot_halted != want_halt_;
  if (!disagree) {
    if (stats_.halt_alarm)
      spdlog::info("link: the robot {} as wanted again after {:.1f} s", want_halt_ ? "stands" : "walks",
                   stats_.halt_alarm_s);
    disagree_since_us_ = 0;
    stats_.halt_alarm = false;
    stats_.halt_alarm_s = 0;
    return;
  }
  if (!disagree_since_us_) disagree_since_us_ = now;
  stats_.halt_alarm_s = (now - disagree_since_us_) * 1e-6;
  if (!stats_.halt_alarm && stats_.halt_alarm_s >= o_.halt_alarm_s) {
    stats_.halt_alarm = true;
    ++stats_.halt_alarms;
    spdlog::error("link: ALARM: the robot {} while the ground station wants it {} ({:.1f} s){}",
                  want_halt_ ? "walks" : "stands", want_halt_ ? "halted" : "walking", stats_.halt_alarm_s,
                  stats_.robot_failsafe ? " (its fail-safe)" : "");
  }
}

bool LinkEndpoint::NextFrame(LinkFrameOut* out, int timeout_ms, const std::atomic<bool>* stop) {
  std::unique_lock<std::mutex> l(mu_);
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (frames_.empty()) {
    if (stop && *stop) return false;
    if (cv_.wait_until(l, std::min(until, std::chrono::steady_clock::now() + std::chrono::milliseconds(50))) ==
            std::cv_status::timeout &&
        std::chrono::steady_clock::now() >= until)
      return false;
  }
  *out = std::move(frames_.front());
  frames_.pop_front();
  ++stats_.frames_delivered;
  return true;
}

std::vector<LinkImuSample> LinkEndpoint::TakeImu() {
  std::lock_guard<std::mutex> l(mu_);
  std::vector<LinkImuSample> v(imu_.begin(), imu_.end());
  imu_.clear();
  return v;
}

void LinkEndpoint::SendControl(uint8_t command, int32_t a0, int32_t a1, int32_t a2) {
  std::lock_guard<std::mutex> l(mu_);
  QueueControl(command, a0, a1, a2);
}

void LinkEndpoint::QueueControl(uint8_t command, int32_t a0, int32_t a1, int32_t a2) {
  PendingControl p;
  p.c.command = command;
  p.c.arg[0] = a0, p.c.arg[1] = a1, p.c.arg[2] = a2;
  p.id = next_control_id_++;
  if (p.id == 0) p.id = next_control_id_++;
  // A newer setting replaces an unacknowledged older one of its kind
  // (halt and resume are one kind).
  const auto kind = [](uint8_t c) { return c == RL_CMD_RESUME ? uint8_t{RL_CMD_HALT} : c; };
  controls_.erase(std::remove_if(controls_.begin(), controls_.end(),
                                 [&](const PendingControl& c) { return kind(c.c.command) == kind(command); }),
                  controls_.end());
  controls_.push_back(p);
}

void LinkEndpoint::SetHalt(bool halt) {
  {
    std::lock_guard<std::mutex> l(mu_);
    if (halt == want_halt_) return;
    want_halt_ = halt;
    halt_acked_ = false;
    last_heartbeat_us_ = 0;  // say it in the next heartbeat too, now
  }
  SendControl(halt ? RL_CMD_HALT : RL_CMD_RESUME);
}

bool LinkEndpoint::HaltAcknowledged() const {
  std::lock_guard<std::mutex> l(mu_);
  return halt_acked_;
}

LinkStats LinkEndpoint::stats() const {
  std::lock_guard<std::mutex> l(mu_);
  LinkStats s = stats_;
  s.frames = reassembler_.stats();
  s.latency_p50_ms = latencies_ms_.Percentile(0.5);
  s.latency_p95_ms = latencies_ms_.Percentile(0.95);
  const int64_t now = LinkNowUs();
  s.synced = clock_.synced();
  s.clock_offset_ms = clock_.OffsetAt(now) * 1e-3;
  s.clock_drift_ppm = clock_.drift_ppm();
  s.clock_best_rtt_ms = clock_.best_delay_us() * 1e-3;
  s.clock_round_trips = clock_.samples();
  s.robot_silent_s = last_heard_us_ ? (now - last_heard_us_) * 1e-6 : (now - start_us_) * 1e-6;
  s.want_halt = want_halt_;
  return s;
}

}  // namespace rumi
