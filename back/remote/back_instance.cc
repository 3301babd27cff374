#include "back/remote/back_instance.h"

#include <memory>

#include "back/remote/remote_dispatcher.h"
#include "common/logging.h"
#include "common/process/exit_codes.h"
#include "common/process/subprocess.h"

namespace rumi {

int RunBackInstance(BackRunOptions run, const DdsOptions& dds, const std::atomic<bool>* stop) {
  const std::string& instance = run.ipc.instance;
  std::string why;
  if (!run.ipc.Check(&why)) {
    spdlog::error("--instance '{}': {}", instance, why);
    return kExitBadInput;
  }
  if (run.work_dir.empty()) {
    spdlog::error("--instance needs --work DIR (for back_stats.json)");
    return kExitBadInput;
  }
  std::unique_ptr<RemoteDispatcher> dispatcher;
  if (run.back.mode != "local") {
    dispatcher = RemoteDispatcher::Create(dds, instance, run.back, &why);
    if (!dispatcher) {
      spdlog::error("back.mode {}: {}", run.back.mode, why);
      return kExitError;
    }
    run.remote = dispatcher.get();
  }
  if (run.back.low_priority) spdlog::info("priority: {}", LowerOwnPriority());
  return RunBack(run, stop);
}

}  // namespace rumi
