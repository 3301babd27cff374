// `rumi view STATE_DIR`: the web view of a session folder (a rumid state
// folder or an eval run folder) without rumid: its saved map, grid, status
// and timeline, read again when they change (docs/view.md).
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

#include "apps/cli/commands.h"
#include "apps/config/rumi_config.h"
#include "apps/view/view_session.h"
#include "common/process/exit_codes.h"
#include "common/process/signals.h"

namespace rumi::cli {

namespace {

// The command line; a port of -1 and empty strings leave the config's view: as it is.
struct ViewArgs {
  std::string dir, config, bind, token;
  int port = -1;
};

[[noreturn]] void Refuse(const std::string& why) {
  std::cerr << "rumi view: " << why << "\n";
  throw CLI::RuntimeError(kExitBadInput);
}

// The config's view: with the command line over it, checked.
ViewSessionOptions SessionOptionsOf(const ViewArgs& a) {
  ViewSessionOptions o;
  try {
    o.view = LoadRumiConfig(a.config).view;
  } catch (const ConfigError& e) {
    Refuse(e.what());
  }
  if (!a.bind.empty()) o.view.bind = a.bind;
  if (a.port >= 0) o.view.port = a.port;
  if (!a.token.empty()) o.view.token = a.token;
  o.state_dir = std::filesystem::absolute(a.dir).string();
  std::string why;
  if (!o.view.Check(&why)) Refuse("view." + why);
  return o;
}

}  // namespace

void RegisterViewCommand(CLI::App* app) {
  auto a = std::make_shared<ViewArgs>();
  CLI::App* cmd = app->add_subcommand("view", "serve the web view of a session folder (its saved map) until Ctrl-C");
  cmd->add_option("dir", a->dir, "a rumid state folder or an eval run folder (holding map.rumi)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--config", a->config, "rumi config (its view: section)");
  cmd->add_option("--bind", a->bind, "address to listen on (default view.bind, 127.0.0.1)");
  cmd->add_option("--port", a->port, "TCP port (default view.port; 0: a free one)");
  cmd->add_option("--token", a->token, "require this token (needed for a bind other than loopback)");
  cmd->callback([a] {
    const ViewSessionOptions o = SessionOptionsOf(*a);
    std::string why;
    ProcessSignals::Install();
    auto session = ViewSession::Start(o, &why);
    if (!session) {
      std::cerr << "rumi view: " << why << "\n";
      throw CLI::RuntimeError(kExitError);
    }
    // The address on stdout, alone on its line: scripts and tests read it.
    std::cout << "rumi view: " << session->Address() << std::endl;
    while (!ProcessSignals::stop()->load()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  });
}

}  // namespace rumi::cli
