// rumi-front: the realtime front end.
//   rumi-front --instance ID --out DIR [--config FILE] [--dataset KIND PATH] ...
// is the process of `rumi eval run` and rumid (RunFront, front/front_run.h):
// the configured source (or the dataset), windows and submaps over shared
// memory. Without --instance it runs offline on a dataset and writes the
// trajectories (TUM), per-frame states and timings:
//   rumi-front --dataset tum|euroc|icl|kitti|folder PATH [--config FILE] [--out DIR]
//              [--bench] [--sync] [--no-pace] [--max-frames N] [--loop N] [--log LEVEL]
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <thread>
#include <chrono>

#include "common/process/exit_codes.h"
#include "common/process/process_info.h"
#include "common/recent_samples.h"
#include "apps/config/process_setup.h"
#include "common/dataset.h"
#include "common/logging.h"
#include "common/trajectory.h"
#include "common/trajectory_eval.h"
#include "front/front.h"
#include "front/front_run.h"
#include "front/frame_replay.h"

namespace rumi {
namespace {

Trajectory TrackedPoses(const Submap& s) {
  Trajectory t;
  for (const FrameRecord& r : s.frames)
    if (r.state == TrackingState::kTracking) t.push_back({r.timestamp, r.T_wc});
  return t;
}

int Main(int argc, char** argv) {
  CLI::App app{"rumi-front: realtime monocular front end"};
  std::string kind_name, path, config_path, out_dir, log_level;
  bool bench = false;
  int max_frames = 0, loop = 1;
  app.add_option("--dataset", kind_name, "dataset kind: tum|euroc|icl|kitti|folder (overrides source:)");
  app.add_option("path", path, "dataset folder (with --dataset)");
  app.add_option("--config", config_path, "rumi YAML config (every section is checked)");
  app.add_option("--out", out_dir, "output folder (trajectories, states, timings)");
  app.add_flag("--bench", bench, "print median / p95 ms per frame");
  app.add_option("--max-frames", max_frames, "stop after N frames (0: all)");
  app.add_option("--loop", loop,
                 "play the sequence N times, forward and backward in turn, with continuing timestamps "
                 "(long-run memory check; prints memory per pass)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--log,--log-level", log_level, "trace|debug|info|warn|error|off (overrides the config)");
  bool sync = false, no_pace = false;
  app.add_flag("--no-pace", no_pace, "feed frames as fast as possible instead of at capture rate");
  app.add_flag("--sync", sync, "run local mapping inline (deterministic; not realtime)");
  // Process mode (docs/eval.md): the configured source (or --dataset),
  // windows and submaps over shared memory.
  std::string instance, rate, odometry_path, imu_path, calibration;
  std::vector<std::string> sets;
  int64_t first_submap_id = 0, replay_start_ns = 0;
  bool daemon = false;
  app.add_option("--instance", instance, "ipc instance: run as the pipeline's front (docs/eval.md); needs --out");
  app.add_option("--odometry", odometry_path,
                 "TUM file of the robot's pose source (body -> odometry world; front.odometry_T_bc gives the "
                 "camera in the body), sent with the submaps so the manager can join submaps vision cannot");
  app.add_option("--imu", imu_path,
                 "IMU file (EuRoC imu0 columns; `rumi synth` writes imu.csv): the gyro predicts each frame's rotation "
                 "(front.gyro_prior, front.imu_T_bc)");
  app.add_option("--calibration", calibration,
                 "with --instance: the dataset's calibration, 'dataset' or a YAML with camera: (overrides "
                 "source.calibration)");
  app.add_option("--rate", rate, "with --instance: replay at R x the recorded rate, or max (overrides source.rate)");
  AddConfigSetOptions(&app, &sets,
                      {{"--resend-interval", "publisher.resend_interval_s"},
                       {"--wait-for-consumers", "publisher.wait_for_consumers_s"}});
  app.add_option("--first-submap-id", first_submap_id, "rumid: submap and window ids start here")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--replay-start-ns", replay_start_ns,
                 "rumid: steady-clock time the dataset's first frame was due (a restarted front joins there)");
  app.add_flag("--daemon", daemon, "rumid: append to the frame files, leave the channels for the next consumer");
  CLI11_PARSE(app, argc, argv);
  ProcessSetup setup("front", config_path, log_level, sets);
  if (!setup.Load()) return kExitBadInput;
  const RumiConfig& config = setup.config();
  if (!instance.empty()) {
    FrontRunOptions o;
    o.stream.source = config.source;
    if (!kind_name.empty()) {
      o.stream.source.kind = "dataset";
      o.stream.source.dataset = kind_name;
      o.stream.source.path = path;
    }
    if (!odometry_path.empty()) o.stream.source.odometry = odometry_path;
    if (!imu_path.empty()) o.stream.source.imu = imu_path;
    if (!calibration.empty()) o.stream.source.calibration = calibration;
    if (!rate.empty()) {
      FrameReplayOptions r;
      if (!ParseReplayRate(rate, &r)) {
        spdlog::error("--rate '{}': expected a positive number or max", rate);
        return kExitBadInput;
      }
      o.stream.source.rate = r.max ? 0.0 : r.rate;
    }
    o.stream.config_path = config_path;
    if (config.has_camera) o.stream.camera = &config.camera;
    o.stream.start_ns = replay_start_ns;
    o.front = config.front;
    if (sync) o.front.local_mapping_thread = false;
    o.sampler = config.sampler;
    o.publisher = config.publisher;
    o.publisher.out_dir = out_dir;
    o.publisher.append_files = daemon;
    o.publisher.keep_segments = daemon;
    o.ipc = config.ipc;
    o.ipc.instance = instance;
    std::string why;
    if (!o.ipc.Check(&why) || !o.publisher.Check(&why)) {
      spdlog::error("{}", why);
      return kExitBadInput;
    }
    o.first_submap_id = first_submap_id;
    o.max_frames = max_frames;
    return RunFront(o, setup.stop());
  }
  cv::setNumThreads(1);  // 2 shared cores: OpenCV threads would fight tracking + mapping

  DatasetOptions dopt;
  if (!ParseDatasetKind(kind_name, &dopt.kind) || path.empty()) {
    std::cerr << "rumi-front: give --dataset KIND PATH (or --instance to run the configured source)\n";
    return kExitBadInput;
  }
  dopt.path = path;
  dopt.config_path = config_path;
  FrontOptions fopt = config.front;
  if (sync) fopt.local_mapping_thread = false;
  auto source = OpenDataset(dopt);
  Front front(fopt, source->camera());
  if (!odometry_path.empty()) {  // the whole pose source up front: offline runs only
    const Trajectory odometry = ReadTumTrajectory(odometry_path);
    for (const StampedPose& p : odometry) front.AddPosePrior(p.t, p.T_wc);
    spdlog::info("rumi-front: pose source {} ({} poses)", odometry_path, odometry.size());
  }
  std::optional<ImuReplay> imu;
  if (!imu_path.empty() && loop > 1) {
    spdlog::error("rumi-front: --imu cannot follow --loop (played backwards, the frames no longer match it)");
    return kExitBadInput;
  }
  if (!imu_path.empty()) {
    try {
      imu.emplace(ReadImuCsv(imu_path));
    } catch (const std::exception& e) {
      spdlog::error("rumi-front: imu: {}", e.what());
      return kExitBadInput;
    }
    spdlog::info("rumi-front: IMU {} ({} samples)", imu_path, imu->size());
  }
  spdlog::info("rumi-front: {} frames, camera {}x{} fx {:.2f}", source->size(), source->camera().width(),
               source->camera().height(), source->camera().fx());
  Frame frame;
  std::vector<Timestamp> all_t;
  int n = 0;
  // Frames are played at their capture rate (as a camera would deliver them),
  // so local mapping gets the time it would get live; reading is not timed.
  const bool pace = !sync && !no_pace;
  std::optional<std::chrono::steady_clock::time_point> play0;
  Timestamp t0 = 0;
  auto feed = [&](Timestamp t, const cv::Mat& image) {
    if (pace) {
      if (!play0) { play0 = std::chrono::steady_clock::now(); t0 = t; }
      std::this_thread::sleep_until(*play0 + std::chrono::nanoseconds(t - t0));
    }
    if (imu)  // as a robot delivers them
      for (const ImuSample& s : imu->Until(t)) front.AddImu(s.t, s.gyro);
    front.Track(t, image);
    all_t.push_back(t);
    ++n;
  };
  if (loop <= 1) {
    while (source->Next(&frame)) {
      if (max_frames > 0 && n >= max_frames) break;
      feed(frame.timestamp, frame.image);
    }
  } else {
    // Long run: the frames are held in memory and played back and forth, so
    // the motion stays continuous at each turn; timestamps keep increasing.
    std::vector<Frame> frames;
    while (source->Next(&frame) && (max_frames <= 0 || static_cast<int>(frames.size()) < max_frames))
      frames.push_back(frame);
    if (frames.size() < 2) throw std::runtime_error("--loop needs at least 2 frames");
    const Timestamp dt = (frames.back().timestamp - frames.front().timestamp) /
                         static_cast<Timestamp>(frames.size() - 1);
    Timestamp t = frames.front().timestamp;
    for (int pass = 0; pass < loop; ++pass) {
      const size_t first = front.timings().size();
      size_t tracked = 0;
      for (size_t k = 0; k < frames.size(); ++k) {
        const Frame& f = frames[pass % 2 == 0 ? k : frames.size() - 1 - k];
        feed(t, f.image);
        tracked += front.state() == TrackingState::kTracking;
        t += dt;
      }
      std::vector<double> ms;
      for (size_t i = first; i < front.timings().size(); ++i) ms.push_back(front.timings()[i].total_ms);
      const Front::MapCounts mc = front.current_map_counts();
      std::cout << "pass " << pass + 1 << "/" << loop << ": " << n << " frames (" << NsToSeconds(t - frames.front().timestamp)
                << " s of stream), tracked " << 100.0 * tracked / frames.size() << " %, median "
                << Percentile(ms, 0.5) << " ms, p95 " << Percentile(ms, 0.95) << " ms, submap "
                << front.current_submap_id() << " with " << mc.good_keyframes << " keyframes (" << mc.keyframes
                << " with culled ones) and " << mc.good_points << " points (" << mc.points << "), "
                << front.FinishedSubmaps().size() << " finished, RSS " << ResidentMiB() << " MiB" << std::endl;
    }
  }
  front.Finish();
  if (const std::string g = front.GyroSummary(); !g.empty()) std::cout << g << "\n";
  const auto& subs = front.FinishedSubmaps();
  const Submap* largest = nullptr;
  for (const Submap& s : subs)
    if (!largest || TrackedPoses(s).size() > TrackedPoses(*largest).size()) largest = &s;

  size_t tracked = 0;
  for (const FrameRecord& r : front.records()) tracked += r.state == TrackingState::kTracking ? 1 : 0;
  std::cout << "frames " << n << ", tracked " << tracked << " (" << 100.0 * tracked / std::max(1, n)
            << " %), submaps " << subs.size() << "\n";

  // Evaluation against ground truth, if any (largest submap, Sim3).
  Trajectory gt;
  for (const auto& [t, T] : source->ground_truth()) gt.push_back({t, T});
  if (largest && !gt.empty() && all_t.size() >= 2 && loop <= 1) {
    const Trajectory est = TrackedPoses(*largest);
    try {
      AteOptions ao;
      const AteResult ate = ComputeAte(est, gt, ao);
      double len = 0;
      for (size_t i = 1; i < ate.pairs.size(); ++i)
        len += (gt[ate.pairs[i].gt].T_wc.translation() - gt[ate.pairs[i - 1].gt].T_wc.translation()).norm();
      const TrackingRate tr = ComputeTrackingRate(all_t, est);
      std::cout << "largest submap " << largest->id << ": " << est.size() << " poses, ATE(Sim3) rmse "
                << ate.translation.rmse << " m over path " << len << " m = "
                << (len > 0 ? 100.0 * ate.translation.rmse / len : 0) << " %, covered rate "
                << 100.0 * tr.covered_rate << " %, frame rate " << 100.0 * tr.frame_rate << " %\n";
    } catch (const std::exception& e) {
      std::cout << "evaluation failed: " << e.what() << "\n";
    }
  }
  if (bench) {
    std::vector<double> ms;
    for (const FrameTiming& t : front.timings()) ms.push_back(t.total_ms);
    std::vector<double> ex;
    for (const FrameTiming& t : front.timings()) ex.push_back(t.extract_ms);
    std::vector<double> wait;
    for (const FrameTiming& t : front.timings()) wait.push_back(t.lock_wait_ms);
    std::cout << "bench map-lock wait: median " << Percentile(wait, 0.5) << " ms, p95 " << Percentile(wait, 0.95)
              << " ms, max " << Percentile(wait, 1.0) << " ms\n";
    std::vector<double> cpu;
    for (const FrameTiming& t : front.timings()) cpu.push_back(t.cpu_ms);
    std::cout << "bench cpu: median " << Percentile(cpu, 0.5) << " ms, p95 " << Percentile(cpu, 0.95)
              << " ms (tracking-thread CPU time per frame)\n";
    std::cout << "bench: " << ms.size() << " frames, median " << Percentile(ms, 0.5) << " ms, p95 "
              << Percentile(ms, 0.95) << " ms, max " << Percentile(ms, 1.0) << " ms (extract median "
              << Percentile(ex, 0.5) << " ms)\n";
  }
  if (!out_dir.empty()) {
    std::filesystem::create_directories(out_dir);
    if (largest) {
      WriteTumTrajectory(out_dir + "/trajectory.txt", TrackedPoses(*largest));
      // The largest submap's keyframes at their final (BA) poses: where a
      // drift comes from, tracking or mapping.
      Trajectory kfs;
      for (const Keyframe& kf : largest->keyframes) kfs.push_back({kf.timestamp, kf.T_wc()});
      WriteTumTrajectory(out_dir + "/keyframes.txt", kfs);
    }
    {
      std::ofstream f(out_dir + "/submaps_trajectory.txt");
      f << "# submap_id timestamp tx ty tz qx qy qz qw (camera->submap world)\n";
      for (const Submap& s : subs)
        for (const StampedPose& p : TrackedPoses(s)) {
          const auto& q = p.T_wc.rotation();
          const auto& t = p.T_wc.translation();
          f << s.id << " " << FormatSeconds(p.t) << " " << t.x() << " " << t.y() << " " << t.z() << " "
            << q.x() << " " << q.y() << " " << q.z() << " " << q.w() << "\n";
        }
    }
    {
      std::ofstream f(out_dir + "/frames.txt");
      f << "# timestamp state submap_id extract_ms track_ms total_ms cpu_ms keypoints inliers\n";
      const auto& recs = front.records();
      const auto& tim = front.timings();
      for (size_t i = 0; i < recs.size() && i < tim.size(); ++i)
        f << FormatSeconds(recs[i].timestamp) << " " << ToString(recs[i].state) << " " << recs[i].submap_id << " "
          << tim[i].extract_ms << " " << tim[i].track_ms << " " << tim[i].total_ms << " " << tim[i].cpu_ms << " " << tim[i].keypoints << " "
          << tim[i].inliers << "\n";
    }
    std::cout << "wrote " << out_dir << "/{trajectory.txt,keyframes.txt,submaps_trajectory.txt,frames.txt}\n";
  }
  return 0;
}

}  // namespace
}  // namespace rumi

int main(int argc, char** argv) {
  try {
    return rumi::Main(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "rumi-front: " << e.what() << "\n";
    return 1;
  }
}
