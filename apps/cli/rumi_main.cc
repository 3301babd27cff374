// rumi: the user-facing command line (evaluation, sequence generation, map queries).
#include <CLI/CLI.hpp>

#include "common/logging.h"
#include "apps/cli/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"rumi: monocular visual SLAM that never gives up on a map"};
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, off");
  rumi::cli::RegisterEvalCommands(&app);
  rumi::cli::AddEvalTableCommand(app.get_subcommand("eval"));
  rumi::cli::AddEvalGridCommand(app.get_subcommand("eval"));
  rumi::cli::AddEvalRunCommand(app.get_subcommand("eval"));
  rumi::cli::AddEvalSessionCommand(app.get_subcommand("eval"));
  rumi::cli::RegisterSynthCommand(&app);
  rumi::cli::RegisterStatusCommand(&app);
  rumi::cli::RegisterConfigCommand(&app);
  rumi::cli::RegisterGridCommand(&app);
  rumi::cli::RegisterQueryCommand(&app);
  rumi::cli::RegisterCalibrateCommand(&app);
  rumi::cli::RegisterRobotSimCommand(&app);
  rumi::cli::RegisterLinkCommand(&app);
  rumi::cli::RegisterViewCommand(&app);
  app.parse_complete_callback([&] { rumi::SetupLogging("rumi", log_level); });
  CLI11_PARSE(app, argc, argv);
  return 0;
}
