#pragma once
// rumi-front in the evaluation pipeline (docs/eval.md process contract):
//   rumi-front --dataset KIND PATH [--config FILE] --out RUNDIR --instance ID [--rate R|max]
// Replays the dataset (FrameReplay), runs the Front on it and publishes
// windows and front submaps over the instance's channels (FrontPublisher).
#include <atomic>
#include <string>

namespace rumi {

struct FrontPipelineArgs {
  std::string dataset_kind;   // tum|euroc|icl|kitti|folder
  std::string dataset_path;
  std::string config_path;    // optional: sections front, sampler, ipc, camera, log_level
  std::string out_dir;        // RUNDIR (required)
  std::string instance;       // ipc instance (required)
  std::string rate = "1.0";   // x recorded speed, or "max"
  int max_frames = 0;         // stop after N delivered + skipped frames (0: all)
  double resend_interval_s = 2.0;
  double wait_for_consumers_s = 30.0;
  std::string odometry_path;  // optional TUM file: external pose source (body -> odometry world)
  std::string log_level;      // overrides the config's log_level when set
  bool install_signal_handlers = true;   // SIGINT/SIGTERM -> stop, write outputs, exit 0
  const std::atomic<bool>* stop = nullptr;  // extra stop request (tests)
};

// Exit code: 0 done (or stopped by a signal), 1 runtime error, 2 bad
// arguments, config or dataset path.
int RunFrontPipeline(const FrontPipelineArgs& args);

}  // namespace rumi
