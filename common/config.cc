#include "common/config.h"

#include "common/atomic_file.h"

#include <sstream>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

namespace rumi {

// A config is a few KB; 16 MiB is no config (and /dev/zero no file).
constexpr uint64_t kMaxConfigBytes = uint64_t(16) << 20;

ConfigSection::ConfigSection()
    : node_(YAML::NodeType::Map), file_("<defaults>"), used_(std::make_shared<std::set<std::string>>()) {}

ConfigSection::ConfigSection(YAML::Node node, std::string file, std::string path)
    : node_(node), file_(std::move(file)), path_(std::move(path)),
      used_(std::make_shared<std::set<std::string>>()) {
  if (!node_ || node_.IsNull()) node_ = YAML::Node(YAML::NodeType::Map);
  if (!node_.IsMap()) throw ConfigError(file_ + ": top level must be a map of keys");
}

std::string ConfigSection::FullKey(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

bool ConfigSection::Has(const std::string& key) const {
  return node_.IsMap() && node_[key] && !node_[key].IsNull();
}

ConfigSection ConfigSection::Child(const std::string& key) {
  ConfigSection c;
  c.file_ = file_;
  c.path_ = FullKey(key);
  c.used_ = used_;
  used_->insert(FullKey(key));
  if (Has(key)) {
    if (!node_[key].IsMap()) Fail(key, "expected a section (map of keys)");
    c.node_ = node_[key];
  }
  return c;
}

namespace {
void MarkUsed(const YAML::Node& node, const std::string& key, std::set<std::string>* used) {
  used->insert(key);
  if (!node.IsMap()) return;
  for (const auto& kv : node) MarkUsed(kv.second, key + "." + kv.first.as<std::string>(), used);
}
}  // namespace

void ConfigSection::Ignore(const std::string& key) {
  if (node_.IsMap() && node_[key]) MarkUsed(node_[key], FullKey(key), used_.get());
}

void ConfigSection::Fail(const std::string& key, const std::string& why) const {
  throw ConfigError(file_ + ": key '" + FullKey(key) + "': " + why);
}

namespace {
void CollectUnknown(const YAML::Node& node, const std::string& path,
                    const std::set<std::string>& used, std::vector<std::string>* out) {
  for (const auto& kv : node) {
    const std::string key = path.empty() ? kv.first.as<std::string>()
                                         : path + "." + kv.first.as<std::string>();
    if (!used.count(key)) {
      out->push_back(key);
    } else if (kv.second.IsMap()) {
      CollectUnknown(kv.second, key, used, out);
    }
  }
}
}  // namespace

void ConfigSection::Finish() const {
  std::vector<std::string> unknown;
  if (node_.IsMap()) CollectUnknown(node_, path_, *used_, &unknown);
  if (unknown.empty()) return;
  std::string msg = file_ + ": unknown key" + (unknown.size() > 1 ? "s" : "") + ":";
  for (const auto& k : unknown) msg += " '" + k + "'";
  throw ConfigError(msg);
}

void ConfigSection::Set(const std::string& dotted_key, const std::string& value) {
  YAML::Node v;
  try {
    v = YAML::Load(value);
  } catch (const YAML::Exception& e) {
    throw ConfigError("--set " + FullKey(dotted_key) + "=" + value + ": not a YAML value: " + e.msg);
  }
  if (!v.IsScalar() && !v.IsNull())
    throw ConfigError("--set " + FullKey(dotted_key) + ": a single value, not '" + value + "'");
  if (!v.IsScalar()) v = YAML::Node(value);  // "" and the like: the text itself
  if (!node_ || node_.IsNull()) node_ = YAML::Node(YAML::NodeType::Map);
  YAML::Node at;
  at.reset(node_);  // Node's operator= assigns the content it refers to; reset() moves the reference
  std::string rest = dotted_key;
  for (size_t dot; (dot = rest.find('.')) != std::string::npos; rest = rest.substr(dot + 1)) {
    const std::string part = rest.substr(0, dot);
    if (part.empty()) throw ConfigError("--set " + dotted_key + ": an empty key part");
    if (!at[part]) at[part] = YAML::Node(YAML::NodeType::Map);
    if (!at[part].IsMap())
      throw ConfigError("--set " + FullKey(dotted_key) + ": '" + part + "' is a value, not a section");
    YAML::Node next = at[part];
    at.reset(next);
  }
  if (rest.empty()) throw ConfigError("--set " + dotted_key + ": an empty key");
  at[rest] = v;
}

void ApplyConfigSets(ConfigSection* root, const std::vector<std::string>& sets) {
  for (const std::string& s : sets) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos || eq == 0) throw ConfigError("--set '" + s + "': expected KEY=VALUE");
    root->Set(s.substr(0, eq), s.substr(eq + 1));
  }
}

ConfigSection LoadConfigFile(const std::string& path) {
  std::string why;
  if (!CheckRegularFile(path, kMaxConfigBytes, &why)) throw ConfigError(path + ": cannot read config file: " + why);
  std::string text;
  if (!ReadFileText(path, &text, &why)) throw ConfigError(path + ": cannot read config file: " + why);
  return LoadConfigString(text, path);
}

namespace {
// yaml-cpp keeps duplicate keys and answers with the first one: a later
// override would be silently ignored, so refuse them (and non-scalar keys).
void CheckKeys(const YAML::Node& node, const std::string& name, const std::string& path) {
  if (node.IsSequence()) {
    for (const auto& item : node) CheckKeys(item, name, path);
    return;
  }
  if (!node.IsMap()) return;
  std::set<std::string> seen;
  for (const auto& kv : node) {
    const int line = kv.first.Mark().line + 1;
    if (!kv.first.IsScalar()) {
      throw ConfigError(name + ": line " + std::to_string(line) + ": keys must be plain names");
    }
    const std::string key = path.empty() ? kv.first.Scalar() : path + "." + kv.first.Scalar();
    if (!seen.insert(kv.first.Scalar()).second) {
      throw ConfigError(name + ": line " + std::to_string(line) + ": duplicate key '" + key + "'");
    }
    CheckKeys(kv.second, name, key);
  }
}
// Refuses aliases (*name) from the parser's events, before a tree exists:
// a few hundred bytes of nested aliases ("billion laughs") stand for
// billions of nodes to whoever walks the tree, and a walk hung rumid's start
// and its SIGHUP reload. A rumi config has no use for them.
class AliasRefuser : public YAML::EventHandler {
 public:
  explicit AliasRefuser(const std::string& name) : name_(name) {}
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override {
    throw ConfigError(name_ + ": line " + std::to_string(mark.line + 1) +
                      ": YAML aliases (*name) are not allowed in a rumi config");
  }
  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}

 private:
  std::string name_;
};
}  // namespace

ConfigSection LoadConfigString(const std::string& yaml, const std::string& name) {
  YAML::Node node;
  try {
    std::istringstream in(yaml);
    YAML::Parser parser(in);
    AliasRefuser refuser(name);
    while (parser.HandleNextDocument(refuser)) {
    }
    node = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    throw ConfigError(name + ": malformed YAML at line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  CheckKeys(node, name, "");
  return ConfigSection(node, name);
}

}  // namespace rumi
