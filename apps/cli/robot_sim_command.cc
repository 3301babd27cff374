// `rumi robot-sim`: a simulated robot on a bad Wi-Fi link. It streams a
// dataset (or a `rumi synth` sequence) to a ground station over UDP with the
// real robot-link protocol and the firmware's own link logic (ipc/link
// SimRobot), with loss, bursts, latency, jitter and a bandwidth cap; IMU
// samples synthesised from the ground truth; a robot clock of its own
// (offset, drift); and it obeys halt/resume: while halted the sequence does
// not advance (the robot stands, its camera keeps streaming the same view).
// docs/robot_link.md.
#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/dataset.h"
#include "common/process/signals.h"
#include "common/timestamp.h"
#include "common/trajectory.h"
#include "common/trajectory_plot.h"
#include "common/imu_synth.h"
#include "ipc/link/latency_plot.h"
#include "ipc/link/link_endpoint.h"
#include "ipc/link/robot_sim.h"
#include "apps/cli/commands.h"

namespace rumi::cli {
namespace {

[[noreturn]] void Fail(const std::string& why, int code = 1) {
  std::cerr << "rumi robot-sim: " << why << "\n";
  throw CLI::RuntimeError(code);
}

struct Args {
  std::string dataset, config, kind = "tum", ground = "127.0.0.1:5600", bind = "127.0.0.1:0";
  std::string groundtruth_out, frames_out, stats_out, key_file;
  bool insecure = false;
  int robot_id = 1, quality = 90, max_frames = 0;
  double loss = 0, burst = 1, latency_ms = 0, jitter_ms = 0, bandwidth_kbps = 0;
  double down_loss = -1;
  double clock_offset_ms = 0, drift_ppm = 0, rate = 1.0, imu_hz = 100, linger_s = 2.0, wait_s = 120;
  uint64_t seed = 1;
};

int64_t SteadyNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void Run(const Args& a) {
  DatasetOptions d;
  if (!ParseDatasetKind(a.kind, &d.kind)) Fail("--kind: unknown dataset kind '" + a.kind + "'", 2);
  d.path = a.dataset;
  // The camera: --config's, else the camera.yaml `rumi synth` writes beside
  // its images, else the dataset's own (TUM fr1-3, EuRoC, KITTI).
  d.config_path = a.config;
  if (d.config_path.empty() && std::filesystem::exists(std::filesystem::path(a.dataset) / "camera.yaml"))
    d.config_path = (std::filesystem::path(a.dataset) / "camera.yaml").string();
  std::unique_ptr<FrameSource> src;
  try {
    src = OpenDataset(d);
  } catch (const std::exception& e) {
    Fail(e.what(), 2);
  }
  if (src->size() == 0) Fail(a.dataset + ": no frames", 2);
  SimRobotOptions so;
  so.ground = a.ground;
  so.bind = a.bind;
  so.robot_id = a.robot_id;
  so.up = {a.loss, a.burst, a.latency_ms, a.jitter_ms, a.bandwidth_kbps};
  so.down = {a.down_loss >= 0 ? a.down_loss : a.loss, a.burst, a.latency_ms, a.jitter_ms, 0};
  so.clock_offset_ms = a.clock_offset_ms;
  so.drift_ppm = a.drift_ppm;
  so.seed = a.seed;
  if (a.key_file.empty() == !a.insecure)
    Fail("give the robot its key (--key FILE, the ground station's link.key_file) or, for an "
         "unauthenticated lab link, --insecure",
         2);
  if (!a.key_file.empty()) {
    std::string why;
    if (!LoadLinkKey(a.key_file, &so.key, &why)) Fail(why, 2);
    so.has_key = true;
  }
  std::unique_ptr<SimRobot> robot;
  try {
    robot = std::make_unique<SimRobot>(so);
  } catch (const std::exception& e) {
    Fail(e.what(), 2);
  }
  const auto& gt = src->ground_truth();
  std::unique_ptr<ImuSynth> imu;
  if (a.imu_hz > 0 && gt.size() >= 2) imu = std::make_unique<ImuSynth>(gt);
  const auto& times = src->timestamps();
  const int64_t frame_interval =
      times.size() >= 2 ? static_cast<int64_t>((times.back() - times.front()) / (times.size() - 1) / a.rate) : 33'000'000;
  std::cout << fmt::format("robot-sim: {} frames of {} to {} (robot port {}), loss {:.0f} % (burst {}), "
                           "latency {} +- {} ms{}, clock {:+.1f} ms {:+.1f} ppm{}\n",
                           src->size(), a.dataset, a.ground, robot->port(), 100 * a.loss, a.burst, a.latency_ms,
                           a.jitter_ms,
                           a.bandwidth_kbps > 0 ? fmt::format(", {} kbit/s", a.bandwidth_kbps) : std::string(),
                           a.clock_offset_ms, a.drift_ppm, imu ? fmt::format(", IMU {} Hz", a.imu_hz) : "");
  std::cout.flush();
  ProcessSignals::Install();
  const std::atomic<bool>* stop = ProcessSignals::stop();

  const int64_t wall_minus_mono = WallNowNs() - SteadyNs();
  std::ofstream frames_csv;
  if (!a.frames_out.empty()) {
    frames_csv.open(a.frames_out);
    if (!frames_csv) Fail("cannot write " + a.frames_out);
    frames_csv << "frame_id,dataset_t,ground_capture_ns,moving\n";
  }
  Trajectory gt_out;  // the dataset's ground truth at each sent frame, stamped with its capture (ground clock)
  auto gt_at = [&](Timestamp t) -> const Se3* {
    if (gt.empty()) return nullptr;
    auto it = std::lower_bound(gt.begin(), gt.end(), t,
                               [](const std::pair<Timestamp, Se3>& p, Timestamp x) { return p.first < x; });
    if (it == gt.end()) --it;
    if (it != gt.begin() && t - (it - 1)->first < it->first - t) --it;
    return std::llabs(it->first - t) <= 20'000'000 ? &it->second : nullptr;
  };

  struct Shot {
    Timestamp data_t = -1;
    std::vector<uint8_t> jpeg;
    int w = 0, h = 0;
  };
  auto encode = [&](const Frame& f, Shot* s) {
    std::vector<uchar> buf;
    if (!cv::imencode(".jpg", f.image, buf, {cv::IMWRITE_JPEG_QUALITY, a.quality})) return false;
    s->jpeg.assign(buf.begin(), buf.end());
    s->data_t = f.timestamp;
    s->w = f.image.cols;
    s->h = f.image.rows;
    return true;
  };
  int sent = 0, sent_halted = 0, halts = 0, too_large = 0, not_captured = 0;
  int64_t capture_due = 0;  // at a frame rate the ground station asked for: the next capture
  int64_t play_ns = 0, halted_ns = 0, waited_ns = 0, last_tick = SteadyNs(), next_imu = 0, last_send = 0;
  Timestamp t0 = -1;
  // The robot stands until it first hears the ground station (rumi_robot.h):
  // that wait is neither a halt nor part of the sequence.
  bool moving = false, heard = false, more = true;
  Shot next, current;
  size_t bytes_sent = 0;
  auto load = [&] {
    Frame f;
    while ((more = src->Next(&f))) {
      if (t0 < 0) t0 = f.timestamp;
      if (encode(f, &next)) return;
    }
  };
  auto send = [&](const Shot& s, bool walking) {
    const int64_t cap = SteadyNs();
    const int64_t id = robot->SendFrame(s.jpeg, s.w, s.h, RL_FORMAT_JPEG, static_cast<uint8_t>(a.quality));
    last_send = cap;
    if (id < 0) {
      ++too_large;
      return;
    }
    ++sent;
    sent_halted += !walking;
    bytes_sent += s.jpeg.size();
    if (const Se3* p = gt_at(s.data_t)) gt_out.push_back({cap + wall_minus_mono, *p});
    if (frames_csv.is_open())
      frames_csv << id << ',' << s.data_t << ',' << cap + wall_minus_mono << ',' << (walking ? 1 : 0) << '\n';
  };
  // The walking state: halts counted, the sequence's clock runs only while
  // the robot walks.
  auto watch = [&](int64_t now) {
    if (!heard) {
      waited_ns += now - last_tick;
      last_tick = now;
      if (!robot->heard()) return;
      // From here on the usual changes count: a station that wants the
      // robot halted from the start (rumi calibrate --link) is a halt.
      heard = moving = true;
      std::cout << fmt::format("robot-sim: heard the ground station after {:.2f} s\n", waited_ns * 1e-9);
      std::cout.flush();
    }
    const bool m = robot->moving();
    if (m != moving) {
      halts += !m;
      std::cout << fmt::format("robot-sim: {} at {:.2f} s of the sequence\n", m ? "resumed" : "halted",
                               play_ns * a.rate * 1e-9);
      std::cout.flush();
      moving = m;
    }
    (moving ? play_ns : halted_ns) += now - last_tick;
    last_tick = now;
  };
  load();
  while (!stop->load() && (more || !next.jpeg.empty())) {
    if (a.max_frames > 0 && sent >= a.max_frames) break;
    const int64_t now = SteadyNs();
    watch(now);
    if (!heard) {  // nothing to stream to yet (its heartbeats go out meanwhile)
      if (a.wait_s > 0 && waited_ns > static_cast<int64_t>(a.wait_s * 1e9))
        Fail(fmt::format("robot-sim: heard no ground station at {} in {:.0f} s (--wait-s)", a.ground, a.wait_s));
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    const Timestamp data_t = t0 + static_cast<int64_t>(play_ns * a.rate);
    if (imu && now >= next_imu) {
      float acc[3], gyr[3];
      imu->Sample(data_t, acc, gyr, moving ? a.rate : 0.0);  // a halted robot stands: gravity only
      robot->AddImu(acc, gyr);
      next_imu = std::max(now, next_imu + static_cast<int64_t>(1e9 / a.imu_hz));
    }
    // The camera's rate: the sequence's, or lower when the ground station
    // asked for less (its rate control, when the link cannot carry more).
    const double fps = robot->asked_fps();
    const int64_t interval = fps > 0 ? std::max(frame_interval, static_cast<int64_t>(1e9 / fps)) : frame_interval;
    if (!next.jpeg.empty() && data_t >= next.data_t) {
      current = std::move(next);
      next = Shot();
      if (fps <= 0 || now >= capture_due - frame_interval / 2) {
        send(current, true);
        capture_due = std::max(capture_due + interval, now - frame_interval);
      } else {
        ++not_captured;
      }
      load();
    } else if (!moving && !current.jpeg.empty() && now - last_send >= interval) {
      send(current, false);  // standing: the same view again
    }
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  // Let the last frames' retransmissions happen before the robot goes away.
  const int64_t linger_until = SteadyNs() + static_cast<int64_t>(a.linger_s * 1e9);
  // (A halt asked for at the very end is still obeyed and counted.)
  while (!stop->load() && SteadyNs() < linger_until) {
    watch(SteadyNs());
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }

  std::string why;
  if (!a.groundtruth_out.empty()) {
    std::ostringstream o;
    FormatTumTrajectory(gt_out, o);
    if (!WriteFileAtomically(a.groundtruth_out, o.str(), &why)) Fail(why);
  }
  const rr_stats rs = robot->stats();
  const int64_t now = LinkNowUs();
  nlohmann::json j = {
      {"frames_sent", sent},
      {"frames_sent_halted", sent_halted},
      {"frames_not_captured", not_captured},  // skipped at the frame rate the ground station asked for
      {"asked_fps", robot->asked_fps()},
      {"frames_too_large", too_large},
      {"mean_frame_bytes", sent ? static_cast<double>(bytes_sent) / sent : 0.0},
      {"halts", halts},
      {"halted_s", halted_ns * 1e-9},
      {"waited_for_ground_s", waited_ns * 1e-9},
      {"fragments_sent", rs.fragments_sent},
      {"fragments_resent", rs.fragments_resent},
      {"nacks_too_old", rs.nacks_too_old},
      {"imu_samples", rs.imu_samples},
      {"failsafe_stops", rs.failsafe_stops},
      {"auth",
       {{"keyed", so.has_key},
        {"sessions", rs.sessions},
        {"unauthenticated", rs.unauthenticated},
        {"failures", rs.auth_failures},
        {"replays", rs.replays},
        {"frames_no_session", rs.frames_no_session}}},
      {"datagrams_lost_up", robot->up_lost()},
      {"datagrams_lost_down", robot->down_lost()},
      {"clock_offset_ms", (robot->RobotClockAt(now) - now) * 1e-3},
      {"drift_ppm", a.drift_ppm},
  };
  if (!a.stats_out.empty() && !WriteFileAtomically(a.stats_out, j.dump(2) + "\n", &why)) Fail(why);
  std::cout << "robot-sim: " << j.dump() << "\n";
}

}  // namespace

void RegisterRobotSimCommand(CLI::App* app) {
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app->add_subcommand("robot-sim", "a simulated robot streaming a sequence over the robot link (UDP)");
  cmd->add_option("dataset", a->dataset, "the sequence's folder (rumi synth output, TUM, EuRoC, ...)")->required();
  cmd->add_option("--kind", a->kind, "dataset layout: tum (rumi synth), folder, euroc, icl, kitti");
  cmd->add_option("--config", a->config, "a config whose camera: section is the dataset's (default: its camera.yaml)");
  cmd->add_option("--ground", a->ground, "the ground station's link address (source.link.bind)");
  cmd->add_option("--bind", a->bind, "the robot's own address (port 0: any)");
  cmd->add_option("--robot-id", a->robot_id, "robot id")->check(CLI::Range(0, 65535));
  cmd->add_option("--key", a->key_file, "the robot's key file (`rumi link keygen`): an authenticated link");
  cmd->add_flag("--insecure", a->insecure, "no key: an unauthenticated link (the ground station's link.insecure)");
  cmd->add_option("--loss", a->loss, "datagram loss probability, both ways")->check(CLI::Range(0.0, 0.9));
  cmd->add_option("--down-loss", a->down_loss, "ground -> robot loss (default: --loss)")->check(CLI::Range(0.0, 0.9));
  cmd->add_option("--burst", a->burst, "mean length of a loss burst (1: independent)")->check(CLI::Range(1.0, 1000.0));
  cmd->add_option("--latency-ms", a->latency_ms, "one-way latency")->check(CLI::Range(0.0, 10000.0));
  cmd->add_option("--jitter-ms", a->jitter_ms, "+- uniform jitter (reorders)")->check(CLI::Range(0.0, 10000.0));
  cmd->add_option("--bandwidth-kbps", a->bandwidth_kbps, "robot -> ground cap, kbit/s (0: none)")
      ->check(CLI::Range(0.0, 1e7));
  cmd->add_option("--clock-offset-ms", a->clock_offset_ms, "robot clock minus ground clock");
  cmd->add_option("--drift-ppm", a->drift_ppm, "robot clock drift")->check(CLI::Range(-1000.0, 1000.0));
  cmd->add_option("--rate", a->rate, "x the recorded speed")->check(CLI::Range(0.01, 100.0));
  cmd->add_option("--quality", a->quality, "JPEG quality 1..100")->check(CLI::Range(1, 100));
  cmd->add_option("--imu-hz", a->imu_hz, "IMU rate from the ground truth (0: none)")->check(CLI::Range(0.0, 2000.0));
  cmd->add_option("--max-frames", a->max_frames, "stop after N frames (0: all)");
  cmd->add_option("--wait-s", a->wait_s, "give up when no ground station is heard within this long (0: wait forever)")
      ->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--linger-s", a->linger_s, "stay this long after the last frame (retransmissions)");
  cmd->add_option("--seed", a->seed, "seed of the losses and jitter");
  cmd->add_option("--groundtruth-out", a->groundtruth_out,
                  "TUM ground truth of the sent frames, stamped with their capture on the ground clock");
  cmd->add_option("--frames-out", a->frames_out, "CSV: frame id, dataset time, ground capture time, walking");
  cmd->add_option("--stats-out", a->stats_out, "JSON of the robot's side");
  cmd->callback([a] { Run(*a); });

  // The link's latency per frame (source.link.frames_log) as a PNG.
  auto csv = std::make_shared<std::string>();
  auto png = std::make_shared<std::string>();
  CLI::App* plot = app->add_subcommand("link-plot", "the robot link's latency per frame (its frames log) as a PNG");
  plot->add_option("frames_log", *csv, "the CSV of source.link.frames_log")->required();
  plot->add_option("--out", *png, "PNG to write (default: beside the CSV, .png)");
  plot->callback([csv, png] {
    std::vector<LinkFrameLogLine> frames;
    std::string why;
    if (!ReadLinkFramesLog(*csv, &frames, &why)) Fail(why, 2);
    const std::string out = png->empty() ? std::filesystem::path(*csv).replace_extension(".png").string() : *png;
    try {
      WritePng(out, RenderLatencyPlot(frames, std::filesystem::path(*csv).filename().string()));
    } catch (const std::exception& e) {
      Fail(e.what());
    }
    std::cout << "link-plot: " << frames.size() << " frames -> " << out << "\n";
  });
}

}  // namespace rumi::cli
