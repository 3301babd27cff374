#include "manager/cli/commands.h"
namespace rumi::cli {
void RegisterSynthCommand(CLI::App* app) { app->add_subcommand("synth", "generate a sequence"); }
}  // namespace rumi::cli
