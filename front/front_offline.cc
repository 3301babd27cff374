#include "front/front_offline.h"

#include <opencv2/core.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "common/atomic_file.h"
#include "common/imu.h"
#include "common/process/exit_codes.h"
#include "common/process/process_info.h"
#include "common/recent_samples.h"
#include "common/trajectory.h"
#include "common/trajectory_eval.h"
#include "front/front.h"
#include "front/front_publisher.h"

namespace rumi {
namespace {

// Feeds frames to the front, at their capture rate when pacing (as a camera
// would deliver them, so local mapping gets the time it would get live;
// reading is not timed), each after the IMU samples up to it.
struct Player {
  Player(Front* f, std::optional<ImuReplay>* i, bool p) : front(f), imu(i), pace(p) {}
  Front* front;
  std::optional<ImuReplay>* imu;
  bool pace;
  std::optional<std::chrono::steady_clock::time_point> play0;
  Timestamp t0 = 0;
  std::vector<Timestamp> all_t;  // every frame fed
  int n = 0;

  void Feed(Timestamp t, const cv::Mat& image) {
    if (pace) {
      if (!play0) { play0 = std::chrono::steady_clock::now(); t0 = t; }
      std::this_thread::sleep_until(*play0 + std::chrono::nanoseconds(t - t0));
    }
    if (*imu)  // as a robot delivers them
      for (const ImuSample& s : (*imu)->Until(t)) front->AddImu(s.t, s.gyro);
    front->Track(t, image);
    all_t.push_back(t);
    ++n;
  }
};

// The pose source (all of it up front: offline runs only) and the IMU file.
// False: bad input, logged.
bool ReadSideInputs(const FrontOfflineOptions& o, Front* front, std::optional<ImuReplay>* imu) {
  if (!o.odometry.empty()) {
    const Trajectory odometry = ReadTumTrajectory(o.odometry);
    for (const StampedPose& p : odometry) front->AddPosePrior(p.t, p.T_wc);
    spdlog::info("rumi-front: pose source {} ({} poses)", o.odometry, odometry.size());
  }
  if (!o.imu.empty() && o.loop > 1) {
    spdlog::error("rumi-front: --imu cannot follow --loop (played backwards, the frames no longer match it)");
    return false;
  }
  if (!o.imu.empty()) {
    try {
      imu->emplace(ReadImuCsv(o.imu));
    } catch (const std::exception& e) {
      spdlog::error("rumi-front: imu: {}", e.what());
      return false;
    }
    spdlog::info("rumi-front: IMU {} ({} samples)", o.imu, (*imu)->size());
  }
  return true;
}

void PrintPass(const Front& front, int pass, int loop, int n, Timestamp stream_ns, size_t tracked, size_t frames,
               size_t first_timing) {
  std::vector<double> ms;
  for (size_t i = first_timing; i < front.timings().size(); ++i) ms.push_back(front.timings()[i].total_ms);
  const Front::MapCounts mc = front.current_map_counts();
  std::cout << "pass " << pass + 1 << "/" << loop << ": " << n << " frames (" << NsToSeconds(stream_ns)
            << " s of stream), tracked " << 100.0 * tracked / frames << " %, median "
            << Percentile(ms, 0.5) << " ms, p95 " << Percentile(ms, 0.95) << " ms, submap "
            << front.current_submap_id() << " with " << mc.good_keyframes << " keyframes (" << mc.keyframes
            << " with culled ones) and " << mc.good_points << " points (" << mc.points << "), "
            << front.FinishedSubmaps().size() << " finished, RSS " << ResidentMiB() << " MiB" << std::endl;
}

// Long run: the frames are held in memory and played back and forth, so the
// motion stays continuous at each turn; timestamps keep increasing.
void PlayLooped(FrameSource* source, const FrontOfflineOptions& o, Player* player) {
  std::vector<Frame> frames;
  Frame frame;
  while (source->Next(&frame) && (o.max_frames <= 0 || static_cast<int>(frames.size()) < o.max_frames))
    frames.push_back(frame);
  if (frames.size() < 2) throw std::runtime_error("--loop needs at least 2 frames");
  const Timestamp dt = (frames.back().timestamp - frames.front().timestamp) /
                       static_cast<Timestamp>(frames.size() - 1);
  Timestamp t = frames.front().timestamp;
  for (int pass = 0; pass < o.loop; ++pass) {
    const size_t first = player->front->timings().size();
    size_t tracked = 0;
    for (size_t k = 0; k < frames.size(); ++k) {
      const Frame& f = frames[pass % 2 == 0 ? k : frames.size() - 1 - k];
      player->Feed(t, f.image);
      tracked += player->front->state() == TrackingState::kTracking;
      t += dt;
    }
    PrintPass(*player->front, pass, o.loop, player->n, t - frames.front().timestamp, tracked, frames.size(), first);
  }
}

void Play(FrameSource* source, const FrontOfflineOptions& o, Player* player) {
  if (o.loop > 1) return PlayLooped(source, o, player);
  Frame frame;
  while (source->Next(&frame)) {
    if (o.max_frames > 0 && player->n >= o.max_frames) break;
    player->Feed(frame.timestamp, frame.image);
  }
}

// The largest submap against the ground truth (Sim3).
void PrintAte(const Submap& largest, const Trajectory& gt, const std::vector<Timestamp>& all_t) {
  const Trajectory est = TrackedPoses(largest);
  try {
    AteOptions ao;
    const AteResult ate = ComputeAte(est, gt, ao);
    double len = 0;
    for (size_t i = 1; i < ate.pairs.size(); ++i)
      len += (gt[ate.pairs[i].gt].T_wc.translation() - gt[ate.pairs[i - 1].gt].T_wc.translation()).norm();
    const TrackingRate tr = ComputeTrackingRate(all_t, est);
    std::cout << "largest submap " << largest.id << ": " << est.size() << " poses, ATE(Sim3) rmse "
              << ate.translation.rmse << " m over path " << len << " m = "
              << (len > 0 ? 100.0 * ate.translation.rmse / len : 0) << " %, covered rate "
              << 100.0 * tr.covered_rate << " %, frame rate " << 100.0 * tr.frame_rate << " %\n";
  } catch (const std::exception& e) {
    std::cout << "evaluation failed: " << e.what() << "\n";
  }
}

void PrintBench(const std::vector<FrameTiming>& timings) {
  std::vector<double> ms, ex, wait, cpu;
  for (const FrameTiming& t : timings) {
    ms.push_back(t.total_ms);
    ex.push_back(t.extract_ms);
    wait.push_back(t.lock_wait_ms);
    cpu.push_back(t.cpu_ms);
  }
  std::cout << "bench map-lock wait: median " << Percentile(wait, 0.5) << " ms, p95 " << Percentile(wait, 0.95)
            << " ms, max " << Percentile(wait, 1.0) << " ms\n";
  std::cout << "bench cpu: median " << Percentile(cpu, 0.5) << " ms, p95 " << Percentile(cpu, 0.95)
            << " ms (tracking-thread CPU time per frame)\n";
  std::cout << "bench: " << ms.size() << " frames, median " << Percentile(ms, 0.5) << " ms, p95 "
            << Percentile(ms, 0.95) << " ms, max " << Percentile(ms, 1.0) << " ms (extract median "
            << Percentile(ex, 0.5) << " ms)\n";
}

void WriteText(const std::string& path, const std::string& text) {
  std::string why;
  if (!WriteFileAtomically(path, text, &why)) throw std::runtime_error(why);
}

void WriteOutputs(const std::string& out_dir, const Front& front, const Submap* largest) {
  std::filesystem::create_directories(out_dir);
  const std::vector<Submap>& subs = front.FinishedSubmaps();
  if (largest) {
    WriteTumTrajectory(out_dir + "/trajectory.txt", TrackedPoses(*largest));
    // The largest submap's keyframes at their final (BA) poses: where a
    // drift comes from, tracking or mapping.
    Trajectory kfs;
    for (const Keyframe& kf : largest->keyframes) kfs.push_back({kf.timestamp, kf.T_wc()});
    WriteTumTrajectory(out_dir + "/keyframes.txt", kfs);
  }
  std::ostringstream f;
  f << "# submap_id timestamp tx ty tz qx qy qz qw (camera->submap world)\n";
  for (const Submap& s : subs)
    for (const StampedPose& p : TrackedPoses(s)) {
      const auto& q = p.T_wc.rotation();
      const auto& t = p.T_wc.translation();
      f << s.id << " " << FormatSeconds(p.t) << " " << t.x() << " " << t.y() << " " << t.z() << " " << q.x() << " "
        << q.y() << " " << q.z() << " " << q.w() << "\n";
    }
  WriteText(out_dir + "/submaps_trajectory.txt", f.str());
  std::ostringstream g;
  g << "# timestamp state submap_id extract_ms track_ms total_ms cpu_ms keypoints inliers\n";
  const auto& recs = front.records();
  const auto& tim = front.timings();
  for (size_t i = 0; i < recs.size() && i < tim.size(); ++i)
    g << FormatSeconds(recs[i].timestamp) << " " << ToString(recs[i].state) << " " << recs[i].submap_id << " "
      << tim[i].extract_ms << " " << tim[i].track_ms << " " << tim[i].total_ms << " " << tim[i].cpu_ms << " "
      << tim[i].keypoints << " " << tim[i].inliers << "\n";
  WriteText(out_dir + "/frames.txt", g.str());
  std::cout << "wrote " << out_dir << "/{trajectory.txt,keyframes.txt,submaps_trajectory.txt,frames.txt}\n";
}

}  // namespace

int RunFrontOffline(const FrontOfflineOptions& o) {
  cv::setNumThreads(1);  // 2 shared cores: OpenCV threads would fight tracking + mapping
  auto source = OpenDataset(o.dataset);
  Front front(o.front, source->camera());
  std::optional<ImuReplay> imu;
  if (!ReadSideInputs(o, &front, &imu)) return kExitBadInput;
  spdlog::info("rumi-front: {} frames, camera {}x{} fx {:.2f}", source->size(), source->camera().width(),
               source->camera().height(), source->camera().fx());
  Player player(&front, &imu, o.pace);
  Play(source.get(), o, &player);
  front.Finish();
  if (const std::string g = front.GyroSummary(); !g.empty()) std::cout << g << "\n";
  const std::vector<Submap>& subs = front.FinishedSubmaps();
  const int largest_index = LargestFrontSubmap(subs);
  const Submap* largest = largest_index >= 0 ? &subs[largest_index] : nullptr;
  const int n = player.n;
  size_t tracked = 0;
  for (const FrameRecord& r : front.records()) tracked += r.state == TrackingState::kTracking ? 1 : 0;
  std::cout << "frames " << n << ", tracked " << tracked << " (" << 100.0 * tracked / std::max(1, n)
            << " %), submaps " << subs.size() << "\n";
  Trajectory gt;
  for (const auto& [t, T] : source->ground_truth()) gt.push_back({t, T});
  if (largest && !gt.empty() && player.all_t.size() >= 2 && o.loop <= 1) PrintAte(*largest, gt, player.all_t);
  if (o.bench) PrintBench(front.timings());
  if (!o.out_dir.empty()) WriteOutputs(o.out_dir, front, largest);
  return kExitDone;
}

}  // namespace rumi
