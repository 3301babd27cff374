#pragma once
// rumi-front's command line (apps/front_main.cc) and the run options it and
// the config give each of its two modes: the pipeline's front (RunFront) and
// the offline run over a dataset (RunFrontOffline).
#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "apps/config/rumi_config.h"
#include "front/front_offline.h"
#include "front/front_run.h"

namespace rumi {

struct FrontCommandLine {
  std::string kind_name, path, config_path, out_dir, log_level;
  std::string instance, rate, odometry_path, imu_path, calibration;
  std::vector<std::string> sets;
  bool bench = false, sync = false, no_pace = false, daemon = false;
  int max_frames = 0, loop = 1;
  int64_t first_submap_id = 0, replay_start_ns = 0;
};

void AddFrontFlags(CLI::App* app, FrontCommandLine* f);

// False (said in the log) when the command line asks for what cannot run.
bool FrontRunOptionsFrom(const FrontCommandLine& f, const RumiConfig& config, FrontRunOptions* out);
bool FrontOfflineOptionsFrom(const FrontCommandLine& f, const RumiConfig& config, FrontOfflineOptions* out);

}  // namespace rumi
