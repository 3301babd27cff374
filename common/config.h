#pragma once
// YAML configuration with strict checking: every key read is recorded, and
// Finish() reports keys nobody read (typos), so a program refuses to start
// on a config it does not fully understand. Errors name file, key and reason.
//
// A configurable part declares its keys once in FooOptions::Spec()
// (common/option_spec.h); ReadOptions(section, &foo) reads them.
#include <yaml-cpp/yaml.h>

#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace rumi {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ConfigSection {
 public:
  ConfigSection();  // empty config (all defaults)
  ConfigSection(YAML::Node node, std::string file, std::string path = "");

  bool Has(const std::string& key) const;
  // Reads key into *value when present; keeps the default when absent.
  // Throws ConfigError on a wrong type.
  template <typename T>
  bool Read(const std::string& key, T* value);
  // As Read, and throws when the value is outside [lo, hi].
  template <typename T>
  bool ReadInRange(const std::string& key, T* value, T lo, T hi);
  // Sub-section (empty when absent; throws when present but not a map).
  ConfigSection Child(const std::string& key);

  // Sets a dotted key below this section ("manager.rebuild_interval_s") to a
  // YAML scalar, making the maps on the way: a command-line `--set`, read
  // afterwards exactly as the file's own keys are (types, ranges, rules).
  // Throws ConfigError when the value is not a scalar or the way is not maps.
  void Set(const std::string& dotted_key, const std::string& value);

  // Marks key and everything below it as used without reading it: a section
  // that belongs to another process in a shared config file.
  void Ignore(const std::string& key);

  // Throws ConfigError listing every key that was present but never read.
  void Finish() const;
  // Throws ConfigError for this section's key with the given reason.
  [[noreturn]] void Fail(const std::string& key, const std::string& why) const;

  const std::string& file() const { return file_; }
  std::string FullKey(const std::string& key) const;

 private:
  YAML::Node node_;
  std::string file_;
  std::string path_;
  std::shared_ptr<std::set<std::string>> used_;
};

// Loads a YAML file; throws ConfigError when missing, unreadable or malformed.
ConfigSection LoadConfigFile(const std::string& path);
ConfigSection LoadConfigString(const std::string& yaml, const std::string& name = "<string>");

// "KEY=VALUE" -> root.Set(KEY, VALUE) for each; throws ConfigError naming the
// argument when one has no '='.
void ApplyConfigSets(ConfigSection* root, const std::vector<std::string>& sets);

// Throws ConfigError "<file>: <section>: <why>" when options.Check fails.
template <typename Options>
void CheckOptions(const Options& o, const ConfigSection& s, const std::string& section) {
  std::string why;
  if (!o.Check(&why)) s.Fail(section, why.empty() ? "invalid options" : why);
}

// ---- implementation of the templates ----
template <typename T>
bool ConfigSection::Read(const std::string& key, T* value) {
  if (!Has(key)) {
    // "key:" with nothing after it is a mistake, not a request for the default.
    const YAML::Node& n = node_;
    if (n.IsMap() && n[key] && n[key].IsNull()) Fail(key, "has no value");
    return false;
  }
  used_->insert(FullKey(key));
  try {
    *value = node_[key].as<T>();
  } catch (const YAML::Exception&) {
    Fail(key, "wrong type (value '" + YAML::Dump(node_[key]) + "')");
  }
  return true;
}

template <typename T>
bool ConfigSection::ReadInRange(const std::string& key, T* value, T lo, T hi) {
  if (!Read(key, value)) return false;
  if (!(*value >= lo && *value <= hi)) {  // written so that NaN fails too
    Fail(key, "value " + YAML::Dump(node_[key]) + " out of range [" + YAML::Dump(YAML::Node(lo)) +
                  ", " + YAML::Dump(YAML::Node(hi)) + "]");
  }
  return true;
}

}  // namespace rumi
