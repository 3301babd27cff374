#include "manager/cli/commands.h"
namespace rumi::cli {
void RegisterEvalCommands(CLI::App* app) { app->add_subcommand("eval", "evaluate trajectories"); }
}  // namespace rumi::cli
