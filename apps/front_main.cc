// rumi-front: the realtime front end.
//   rumi-front --instance ID --out DIR [--config FILE] [--dataset KIND PATH] ...
// is the process of `rumi eval run` and rumid (RunFront, front/front_run.h):
// the configured source (or the dataset), windows and submaps over shared
// memory. Without --instance it runs offline on a dataset and writes the
// trajectories (TUM), per-frame states and timings (RunFrontOffline,
// front/front_offline.h):
//   rumi-front --dataset tum|euroc|icl|kitti|folder PATH [--config FILE] [--out DIR]
//              [--bench] [--sync] [--no-pace] [--max-frames N] [--loop N] [--log LEVEL]
// The flags and what they set: apps/config/front_command_line.h.
#include <CLI/CLI.hpp>

#include <iostream>

#include "apps/config/front_command_line.h"
#include "apps/config/process_setup.h"
#include "common/process/exit_codes.h"

namespace rumi {
namespace {

int Main(int argc, char** argv) {
  CLI::App app{"rumi-front: realtime monocular front end"};
  FrontCommandLine f;
  AddFrontFlags(&app, &f);
  CLI11_PARSE(app, argc, argv);
  ProcessSetup setup("front", f.config_path, f.log_level, f.sets);
  if (!setup.Load()) return kExitBadInput;
  if (!f.instance.empty()) {
    FrontRunOptions o;
    return FrontRunOptionsFrom(f, setup.config(), &o) ? RunFront(o, setup.stop()) : kExitBadInput;
  }
  FrontOfflineOptions o;
  return FrontOfflineOptionsFrom(f, setup.config(), &o) ? RunFrontOffline(o) : kExitBadInput;
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
