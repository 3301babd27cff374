#pragma once
// What every rumi process's main does before its Run* entry, written once:
// (AddConfigSetOptions gives a main `--set KEY=VALUE` and its short aliases)
// load the whole config strictly (exit 2 naming file, key and reason), set up
// logging (the command line's level wins over the config's), install the
// signal handlers (common/process/signals.h) and re-read the config on SIGHUP
// to apply the new log level (the rest needs a restart, said in the log).
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/process/signals.h"
#include "apps/config/rumi_config.h"

namespace rumi {

// `--set KEY=VALUE` (repeatable) on app, into *sets, and one alias per
// {flag, key}: `--flag V` is `--set key=V`. The options are declared once,
// in their Spec(); the command line reaches them through the same reader as
// the file, so their ranges and rules hold for it too.
void AddConfigSetOptions(CLI::App* app, std::vector<std::string>* sets,
                         const std::vector<std::pair<std::string, std::string>>& aliases = {});

class ProcessSetup {
 public:
  // name: the logger ("front", "back", "manager", "rumid").
  // sets: the command line's --set KEY=VALUE, applied over the file at every
  // load (and SIGHUP reload).
  ProcessSetup(std::string name, std::string config_path, std::string cli_log_level,
               std::vector<std::string> sets = {});
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
  std::vector<std::string> sets_;
  RumiConfig config_;
  std::function<void()> hook_;
  std::unique_ptr<ReloadOnHangup> reload_;
};

}  // namespace rumi
