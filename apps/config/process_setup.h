#pragma once
// What every rumi process's main does before its Run* entry, written once:
// load the whole config strictly (exit 2 naming file, key and reason), set up
// logging (the command line's level wins over the config's), install the
// signal handlers (common/process/signals.h) and re-read the config on SIGHUP
// to apply the new log level (the rest needs a restart, said in the log).
#include <functional>
#include <memory>
#include <string>

#include "common/process/signals.h"
#include "apps/config/rumi_config.h"

namespace rumi {

class ProcessSetup {
 public:
  // name: the logger ("front", "back", "manager", "rumid").
  ProcessSetup(std::string name, std::string config_path, std::string cli_log_level);
  // False (logged) on a bad config: the main returns kExitBadInput.
  bool Load();
  const RumiConfig& config() const { return config_; }
  RumiConfig* mutable_config() { return &config_; }
  const std::atomic<bool>* stop() const { return ProcessSignals::stop(); }
  // Called after each SIGHUP's reload (rumid forwards it to its children).
  void set_reload_hook(std::function<void()> hook) { hook_ = std::move(hook); }

 private:
  void Reload();

  std::string name_, config_path_, cli_log_level_;
  RumiConfig config_;
  std::function<void()> hook_;
  std::unique_ptr<ReloadOnHangup> reload_;
};

}  // namespace rumi
