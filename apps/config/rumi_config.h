#pragma once
// The one loader of a rumi config file, used by every process (rumi-front,
// rumi-back, rumi-manager, rumid, `rumi eval run`, `rumi config check`).
// It reads every section of every part, so a typo or an out-of-range value
// anywhere stops every process with the file, the key and the reason, not
// only the process that owns the section. Each section's keys are declared
// once, in its options struct (common/option_spec.h).
//
//   log_level: info                       trace|debug|info|warn|error|critical|off
//   camera:    PinholeCameraOptions       (optional: datasets bring their own)
//   source:    SourceOptions              front/frame_stream.h
//   front:     FrontOptions               front/front_options.h
//   sampler:   SamplerOptions             front/sampler.h
//   publisher: FrontPublisherOptions      front/front_publisher.h
//   back:      BackOptions                back/back_options.h
//   manager:   ManagerOptions + ManagerLoopOptions   manager/manager_options.h, manager_run.h
//   grid:      GridOptions                manager/grid/grid_builder.h
//   dds:       DdsOptions                 ipc/dds/dds_options.h
//   ipc:       IpcOptions                 ipc/channels.h
//   daemon:    DaemonOptions              apps/config/daemon_options.h
//   view:      ViewOptions                apps/view/view_options.h
#include <string>
#include <vector>

#include "back/back_options.h"
#include "common/camera_config.h"
#include "front/frame_stream.h"
#include "front/front_options.h"
#include "front/front_publisher.h"
#include "front/sampler.h"
#include "ipc/channels.h"
#include "apps/config/daemon_options.h"
#include "apps/view/view_options.h"
#include "ipc/dds/dds_options.h"
#include "manager/grid/grid_builder.h"
#include "manager/manager_options.h"
#include "manager/manager_run.h"

namespace rumi {

struct RumiConfig {
  std::string file;  // where it came from; "" = defaults only
  std::string log_level = "info";
  bool has_camera = false;
  PinholeCameraOptions camera;
  SourceOptions source;
  FrontOptions front;
  SamplerOptions sampler;
  FrontPublisherOptions publisher;
  BackOptions back;
  ManagerOptions manager;
  ManagerLoopOptions manager_loop;
  GridOptions grid;
  DdsOptions dds;
  IpcOptions ipc;
  DaemonOptions daemon;
  ViewOptions view;
};

// Throws ConfigError ("<file>: key 'front.fps': ...") on a missing or
// malformed file, an unknown key in any section, a wrong type or a value out
// of range. "" gives the defaults.
RumiConfig LoadRumiConfig(const std::string& path);
// The same with command-line "KEY=VALUE" overrides applied to the file's
// keys before they are read (ApplyConfigSets): ranges and rules hold for
// them as for the file.
RumiConfig LoadRumiConfig(const std::string& path, const std::vector<std::string>& sets);
RumiConfig LoadRumiConfigString(const std::string& yaml, const std::string& name = "<string>");

// Every key with its value in `c` (the defaults: RumiConfig()), its range
// and help, by section, in file order: `rumi config defaults`, the docs.
struct ConfigSectionInfo {
  std::string section;
  std::vector<OptionInfo> options;
};
std::vector<ConfigSectionInfo> DescribeRumiConfig(const RumiConfig& c);

// The sections whose values differ (SIGHUP: what changed, what needs a restart).
std::vector<std::string> ChangedSections(const RumiConfig& a, const RumiConfig& b);

}  // namespace rumi
