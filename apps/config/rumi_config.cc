#include "apps/config/rumi_config.h"

namespace rumi {
namespace {

const std::vector<std::string>& LogLevels() {
  static const std::vector<std::string> levels = {"trace", "debug", "info", "warn", "error", "critical", "off"};
  return levels;
}

template <typename O>
void ReadSection(ConfigSection& root, const char* name, O* o) {
  ConfigSection s = root.Child(name);
  ReadOptions(s, o);
}

RumiConfig Load(ConfigSection root, const std::string& file) {
  RumiConfig c;
  c.file = file;
  if (root.Read("log_level", &c.log_level)) {
    bool known = false;
    for (const std::string& l : LogLevels()) known |= l == c.log_level;
    if (!known) root.Fail("log_level", "'" + c.log_level + "' is not one of trace|debug|info|warn|error|critical|off");
  }
  c.has_camera = root.Has("camera");
  ReadSection(root, "camera", &c.camera);
  ReadSection(root, "source", &c.source);
  ReadSection(root, "front", &c.front);
  ReadSection(root, "sampler", &c.sampler);
  ReadSection(root, "publisher", &c.publisher);
  ReadSection(root, "back", &c.back);
  {
    ConfigSection m = root.Child("manager");  // two specs share it: merging and the loop
    ReadOptions(m, &c.manager);
    ReadOptions(m, &c.manager_loop);
  }
  ReadSection(root, "grid", &c.grid);
  ReadSection(root, "dds", &c.dds);
  ReadSection(root, "ipc", &c.ipc);
  ReadSection(root, "daemon", &c.daemon);
  ReadSection(root, "view", &c.view);
  root.Finish();
  return c;
}

template <typename O>
void Describe(std::vector<ConfigSectionInfo>* out, const std::string& section, const O& o) {
  std::vector<OptionInfo> v = O::Spec().Describe(o);
  for (ConfigSectionInfo& s : *out) {
    if (s.section == section) {
      s.options.insert(s.options.end(), v.begin(), v.end());
      return;
    }
  }
  out->push_back({section, std::move(v)});
}

}  // namespace

RumiConfig LoadRumiConfig(const std::string& path) {
  if (path.empty()) return RumiConfig();
  return Load(LoadConfigFile(path), path);
}

RumiConfig LoadRumiConfig(const std::string& path, const std::vector<std::string>& sets) {
  if (sets.empty()) return LoadRumiConfig(path);
  const std::string name = path.empty() ? std::string("--set") : path + " with --set";
  ConfigSection root = path.empty() ? LoadConfigString("{}", name) : LoadConfigFile(path);
  ApplyConfigSets(&root, sets);
  return Load(root, name);
}

RumiConfig LoadRumiConfigString(const std::string& yaml, const std::string& name) {
  return Load(LoadConfigString(yaml, name), name);
}

std::vector<ConfigSectionInfo> DescribeRumiConfig(const RumiConfig& c) {
  std::string levels;
  for (const std::string& l : LogLevels()) levels += (levels.empty() ? "" : "|") + l;
  std::vector<ConfigSectionInfo> out = {{"", {{"log_level", "'" + c.log_level + "'", levels, "log level of every process"}}}};
  Describe(&out, "camera", c.camera);
  Describe(&out, "source", c.source);
  Describe(&out, "front", c.front);
  Describe(&out, "sampler", c.sampler);
  Describe(&out, "publisher", c.publisher);
  Describe(&out, "back", c.back);
  Describe(&out, "manager", c.manager);
  Describe(&out, "manager", c.manager_loop);
  Describe(&out, "grid", c.grid);
  Describe(&out, "dds", c.dds);
  Describe(&out, "ipc", c.ipc);
  Describe(&out, "daemon", c.daemon);
  Describe(&out, "view", c.view);
  return out;
}

std::vector<std::string> ChangedSections(const RumiConfig& a, const RumiConfig& b) {
  const std::vector<ConfigSectionInfo> da = DescribeRumiConfig(a), db = DescribeRumiConfig(b);
  std::vector<std::string> changed;
  for (size_t i = 0; i < da.size() && i < db.size(); ++i) {
    bool same = da[i].options.size() == db[i].options.size();
    for (size_t k = 0; same && k < da[i].options.size(); ++k) same = da[i].options[k].value == db[i].options[k].value;
    if (!same) changed.push_back(da[i].section.empty() ? "log_level" : da[i].section);
  }
  return changed;
}

}  // namespace rumi
