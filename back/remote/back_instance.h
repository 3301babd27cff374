#pragma once
// `rumi-back --instance ID --work DIR` (rumi-back's main, for `rumi eval
// run` and rumid): its options checked, then RunBack (back/back_run.h) at
// low priority, with the DDS dispatcher that back.mode remote or both
// build the windows through (remote_dispatcher.h).
#include <atomic>

#include "back/back_run.h"
#include "ipc/dds/dds_options.h"

namespace rumi {

// run.remote is set here (the dispatcher lives as long as the run). Exit
// code as RunBack's, or bad input (a bad instance, no work_dir), or error
// (the dispatcher cannot be set up).
int RunBackInstance(BackRunOptions run, const DdsOptions& dds, const std::atomic<bool>* stop);

}  // namespace rumi
