// `rumi eval table RUN_DIR...`: the paper's Table IV from `rumi eval run` outputs.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "common/atomic_file.h"
#include "common/eval_table.h"
#include "apps/cli/commands.h"

namespace rumi::cli {
namespace fs = std::filesystem;

namespace {

std::string ReadText(const fs::path& p) {
  std::string text, why;
  if (!ReadFileText(p.string(), &text, &why)) throw std::runtime_error(why);
  return text;
}

// A run dir holds metrics.json itself or one run_* folder per run.
TableRow LoadRow(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw std::runtime_error(dir.string() + ": not a directory");
  std::vector<fs::path> files;
  if (fs::exists(dir / "metrics.json")) files.push_back(dir / "metrics.json");
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.is_directory() && fs::exists(e.path() / "metrics.json")) files.push_back(e.path() / "metrics.json");
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) throw std::runtime_error(dir.string() + ": no metrics.json (nor run_*/metrics.json)");
  TableRow row;
  for (const auto& f : files) row.runs.push_back(ParseRunMetrics(ReadText(f), f.string()));
  row.sequence = row.runs.front().sequence.empty() ? fs::absolute(dir).lexically_normal().filename().string()
                                                   : row.runs.front().sequence;
  return row;
}

}  // namespace

void AddEvalTableCommand(CLI::App* eval) {
  auto* cmd = eval->add_subcommand("table", "print the paper's Table IV (markdown and CSV) from run dirs");
  auto dirs = std::make_shared<std::vector<std::string>>();
  auto csv_path = std::make_shared<std::string>();
  auto format = std::make_shared<std::string>("both");
  cmd->add_option("run_dirs", *dirs, "output folders of `rumi eval run`")->required();
  cmd->add_option("--csv", *csv_path, "also write the CSV table to this file");
  cmd->add_option("--format", *format, "md, csv or both")->check(CLI::IsMember({"md", "csv", "both"}));
  cmd->callback([dirs, csv_path, format] {
    std::vector<TableRow> rows;
    try {
      for (const auto& d : *dirs) rows.push_back(LoadRow(d));
    } catch (const std::exception& e) {
      std::cerr << "rumi eval table: " << e.what() << "\n";
      throw CLI::RuntimeError(2);
    }
    const std::string csv = FormatEvalTableCsv(rows);
    if (*format != "csv") std::cout << FormatEvalTableMarkdown(rows);
    if (*format == "both") std::cout << "\n";
    if (*format != "md") std::cout << csv;
    if (!csv_path->empty()) {
      std::ofstream out(*csv_path);
      if (!(out << csv)) {
        std::cerr << "rumi eval table: cannot write " << *csv_path << "\n";
        throw CLI::RuntimeError(2);
      }
    }
  });
}

}  // namespace rumi::cli
