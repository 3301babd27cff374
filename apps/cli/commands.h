#pragma once
// Each subcommand of the `rumi` CLI registers itself here.
#include <CLI/CLI.hpp>

namespace rumi::cli {

void RegisterEvalCommands(CLI::App* app);   // eval_command.cc: eval ate (later eval run/table)
void RegisterSynthCommand(CLI::App* app);   // synth_command.cc
void AddEvalTableCommand(CLI::App* eval);   // eval_table_command.cc: under `eval`
void AddEvalRunCommand(CLI::App* eval);     // eval_run_command.cc: under `eval`
void AddEvalSessionCommand(CLI::App* eval); // eval_run_command.cc: a rumid session
void RegisterStatusCommand(CLI::App* app);  // status_command.cc
void RegisterConfigCommand(CLI::App* app);  // config_command.cc
void RegisterGridCommand(CLI::App* app);    // grid_command.cc
void AddEvalGridCommand(CLI::App* eval);    // grid_command.cc: under `eval`
void RegisterQueryCommand(CLI::App* app);   // query_command.cc: the map over DDS
void RegisterCalibrateCommand(CLI::App* app);  // calibrate_command.cc: camera from chessboard photos
void RegisterRobotSimCommand(CLI::App* app);   // robot_sim_command.cc: a simulated robot on the link
void RegisterLinkCommand(CLI::App* app);       // link_command.cc: `rumi link keygen`
void RegisterViewCommand(CLI::App* app);       // view_command.cc: the web view of a session folder

}  // namespace rumi::cli
