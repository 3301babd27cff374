#include "apps/config/front_command_line.h"

#include <spdlog/spdlog.h>

#include <iostream>

#include "apps/config/process_setup.h"
#include "front/frame_replay.h"

namespace rumi {

void AddFrontFlags(CLI::App* app, FrontCommandLine* f) {
  app->add_option("--dataset", f->kind_name, "dataset kind: tum|euroc|icl|kitti|folder (overrides source:)");
  app->add_option("path", f->path, "dataset folder (with --dataset)");
  app->add_option("--config", f->config_path, "rumi YAML config (every section is checked)");
  app->add_option("--out", f->out_dir, "output folder (trajectories, states, timings)");
  app->add_flag("--bench", f->bench, "print median / p95 ms per frame");
  app->add_option("--max-frames", f->max_frames, "stop after N frames (0: all)");
  app->add_option("--loop", f->loop,
                  "play the sequence N times, forward and backward in turn, with continuing timestamps "
                  "(long-run memory check; prints memory per pass)")
      ->check(CLI::Range(1, 100000));
  app->add_option("--log,--log-level", f->log_level, "trace|debug|info|warn|error|off (overrides the config)");
  app->add_flag("--no-pace", f->no_pace, "feed frames as fast as possible instead of at capture rate");
  app->add_flag("--sync", f->sync, "run local mapping inline (not realtime; repeatable when front.local_ba_max_time_s never cuts)");
  // Process mode (docs/eval.md): the configured source (or --dataset),
  // windows and submaps over shared memory.
  app->add_option("--instance", f->instance, "ipc instance: run as the pipeline's front (docs/eval.md); needs --out");
  app->add_option("--odometry", f->odometry_path,
                  "TUM file of the robot's pose source (body -> odometry world; front.odometry_T_bc gives the "
                  "camera in the body), sent with the submaps so the manager can join submaps vision cannot");
  app->add_option("--imu", f->imu_path,
                  "IMU file (EuRoC imu0 columns; `rumi synth` writes imu.csv): the gyro predicts each frame's "
                  "rotation (front.gyro_prior, front.imu_T_bc)");
  app->add_option("--calibration", f->calibration,
                  "with --instance: the dataset's calibration, 'dataset' or a YAML with camera: (overrides "
                  "source.calibration)");
  app->add_option("--rate", f->rate,
                  "with --instance: replay at R x the recorded rate, or max (overrides source.rate)");
  AddConfigSetOptions(app, &f->sets,
                      {{"--resend-interval", "publisher.resend_interval_s"},
                       {"--wait-for-consumers", "publisher.wait_for_consumers_s"}});
  app->add_option("--first-submap-id", f->first_submap_id, "rumid: submap and window ids start here")
      ->check(CLI::NonNegativeNumber);
  app->add_option("--replay-start-ns", f->replay_start_ns,
                  "rumid: steady-clock time the dataset's first frame was due (a restarted front joins there)");
  app->add_flag("--daemon", f->daemon, "rumid: append to the frame files, leave the channels for the next consumer");
}

bool FrontRunOptionsFrom(const FrontCommandLine& f, const RumiConfig& config, FrontRunOptions* out) {
  FrontRunOptions& o = *out;
  o.stream.source = config.source;
  if (!f.kind_name.empty()) {
    o.stream.source.kind = "dataset";
    o.stream.source.dataset = f.kind_name;
    o.stream.source.path = f.path;
  }
  if (!f.odometry_path.empty()) o.stream.source.odometry = f.odometry_path;
  if (!f.imu_path.empty()) o.stream.source.imu = f.imu_path;
  if (!f.calibration.empty()) o.stream.source.calibration = f.calibration;
  if (!f.rate.empty()) {
    FrameReplayOptions r;
    if (!ParseReplayRate(f.rate, &r)) {
      spdlog::error("--rate '{}': expected a positive number or max", f.rate);
      return false;
    }
    o.stream.source.rate = r.max ? 0.0 : r.rate;
  }
  o.stream.config_path = f.config_path;
  if (config.has_camera) o.stream.camera = &config.camera;
  o.stream.start_ns = f.replay_start_ns;
  o.front = config.front;
  if (f.sync) o.front.local_mapping_thread = false;
  o.sampler = config.sampler;
  o.publisher = config.publisher;
  o.publisher.out_dir = f.out_dir;
  o.publisher.append_files = o.publisher.keep_segments = f.daemon;
  o.ipc = config.ipc;
  o.ipc.instance = f.instance;
  std::string why;
  if (!o.ipc.Check(&why) || !o.publisher.Check(&why)) {
    spdlog::error("{}", why);
    return false;
  }
  o.first_submap_id = f.first_submap_id;
  o.max_frames = f.max_frames;
  return true;
}

bool FrontOfflineOptionsFrom(const FrontCommandLine& f, const RumiConfig& config, FrontOfflineOptions* out) {
  FrontOfflineOptions& o = *out;
  if (!ParseDatasetKind(f.kind_name, &o.dataset.kind) || f.path.empty()) {
    std::cerr << "rumi-front: give --dataset KIND PATH (or --instance to run the configured source)\n";
    return false;
  }
  o.dataset.path = f.path;
  o.dataset.config_path = f.config_path;
  o.front = config.front;
  if (f.sync) o.front.local_mapping_thread = false;
  o.odometry = f.odometry_path;
  o.imu = f.imu_path;
  o.out_dir = f.out_dir;
  o.bench = f.bench;
  o.pace = !f.sync && !f.no_pace;
  o.max_frames = f.max_frames;
  o.loop = f.loop;
  return true;
}

}  // namespace rumi
