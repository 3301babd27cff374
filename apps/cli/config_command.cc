// `rumi config check FILE`: loads a config the way every rumi process does
// (every section, strictly) and says what is wrong, or that it is fine.
// `rumi config defaults`: every key with its default, range and meaning.
#include <iostream>
#include <memory>

#include "apps/config/rumi_config.h"
#include "apps/cli/commands.h"

namespace rumi::cli {

void RegisterConfigCommand(CLI::App* app) {
  CLI::App* cfg = app->add_subcommand("config", "check a config file, or list every option");
  cfg->require_subcommand(1);
  auto path = std::make_shared<std::string>();
  CLI::App* check = cfg->add_subcommand("check", "load FILE as every rumi process does; exit 2 naming the problem");
  check->add_option("file", *path, "rumi YAML config")->required();
  check->callback([path] {
    try {
      const RumiConfig c = LoadRumiConfig(*path);
      std::cout << *path << ": ok (source " << c.source.kind << (c.source.path.empty() ? "" : " " + c.source.path)
                << (c.has_camera ? ", camera " + std::to_string(c.camera.width) + "x" + std::to_string(c.camera.height)
                                 : ", no camera section")
                << ")\n";
    } catch (const ConfigError& e) {
      std::cerr << e.what() << "\n";
      throw CLI::RuntimeError(2);
    }
  });
  CLI::App* defaults = cfg->add_subcommand("defaults", "every option: key, default, range, meaning (YAML comments)");
  defaults->callback([] {
    for (const ConfigSectionInfo& s : DescribeRumiConfig(RumiConfig())) {
      const std::string indent = s.section.empty() ? "" : "  ";
      if (!s.section.empty()) std::cout << s.section << ":\n";
      for (const OptionInfo& o : s.options) {
        std::cout << indent << o.key << ": " << (o.value.empty() ? "''" : o.value);
        std::string note = o.help;
        if (!o.range.empty()) note += (note.empty() ? "" : "; ") + o.range;
        if (!note.empty()) std::cout << "  # " << note;
        std::cout << "\n";
      }
    }
  });
}

}  // namespace rumi::cli
