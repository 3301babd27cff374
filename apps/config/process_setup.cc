#include "apps/config/process_setup.h"

#include "common/logging.h"

namespace rumi {

ProcessSetup::ProcessSetup(std::string name, std::string config_path, std::string cli_log_level,
                           std::vector<std::string> sets)
    : name_(std::move(name)),
      config_path_(std::move(config_path)),
      cli_log_level_(std::move(cli_log_level)),
      sets_(std::move(sets)) {}

void AddConfigSetOptions(CLI::App* app, std::vector<std::string>* sets,
                         const std::vector<std::pair<std::string, std::string>>& aliases) {
  app->add_option("--set", *sets,
                  "KEY=VALUE: a config option over the file's (e.g. manager.rebuild_interval_s=2); repeatable, "
                  "checked as the file is (`rumi config defaults` lists every key)");
  for (const auto& [flag, key] : aliases) {
    const std::string k = key;
    app->add_option_function<std::string>(
        flag, [sets, k](const std::string& v) { sets->push_back(k + "=" + v); }, "= --set " + k + "=V");
  }
}

bool ProcessSetup::Load() {
  try {
    config_ = LoadRumiConfig(config_path_, sets_);
  } catch (const ConfigError& e) {
    SetupLogging(name_, cli_log_level_.empty() ? "info" : cli_log_level_);
    spdlog::error("{}", e.what());
    return false;
  }
  SetupLogging(name_, cli_log_level_.empty() ? config_.log_level : cli_log_level_);
  ProcessSignals::Install();
  if (!config_path_.empty()) reload_ = std::make_unique<ReloadOnHangup>([this] { Reload(); });
  return true;
}

void ProcessSetup::Reload() {
  RumiConfig fresh;
  try {
    fresh = LoadRumiConfig(config_path_, sets_);
  } catch (const ConfigError& e) {
    spdlog::error("SIGHUP: {}; keeping the running configuration", e.what());
    return;
  }
  std::string changed;
  for (const std::string& s : ChangedSections(config_, fresh))
    if (s != "log_level") changed += (changed.empty() ? "" : ", ") + s;
  if (cli_log_level_.empty() && fresh.log_level != config_.log_level) {
    SetupLogging(name_, fresh.log_level);
    spdlog::info("SIGHUP: log level now {}", fresh.log_level);
  }
  if (!changed.empty()) spdlog::warn("SIGHUP: {} changed in {}: applied at the next restart", changed, config_path_);
  config_.log_level = fresh.log_level;
  if (hook_) hook_();
}

}  // namespace rumi
