// The option tables of the docs against the options' one declaration
// (Spec(), via DescribeRumiConfig): every key a table lists exists in its
// section and its default is the declared one. A table copied by hand goes
// stale silently; this test says where.
#include "apps/config/rumi_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

namespace rumi {
namespace {

const std::string kDocs = std::string(RUMI_SOURCE_DIR) + "/docs/";

struct Row {
  int line;
  std::string key, value;
};

std::string Strip(std::string s) {
  std::string out;
  for (char c : s)
    if (c != '`') out += c;
  const size_t b = out.find_first_not_of(" \t"), e = out.find_last_not_of(" \t");
  return b == std::string::npos ? "" : out.substr(b, e - b + 1);
}

std::vector<std::string> Cells(const std::string& line) {
  std::vector<std::string> cells;
  std::string cur;
  for (size_t i = 1; i < line.size(); ++i) {
    if (line[i] == '\\' && i + 1 < line.size() && line[i + 1] == '|') {
      cur += '|';
      ++i;
    } else if (line[i] == '|') {
      cells.push_back(Strip(cur));
      cur.clear();
    } else {
      cur += line[i];
    }
  }
  return cells;
}

// The rows of the first table whose header starts "| key ... | default |".
std::vector<Row> OptionTable(const std::string& doc) {
  std::ifstream in(kDocs + doc);
  EXPECT_TRUE(in) << doc;
  std::vector<Row> rows;
  std::string line;
  bool inside = false;
  for (int n = 1; std::getline(in, line); ++n) {
    if (!inside) {
      const std::vector<std::string> h = line.rfind("|", 0) == 0 ? Cells(line) : std::vector<std::string>{};
      inside = h.size() >= 2 && h[0].rfind("key", 0) == 0 && h[1] == "default";
      if (inside) std::getline(in, line), ++n;  // the |---| line
      continue;
    }
    if (line.rfind("|", 0) != 0) break;
    const std::vector<std::string> c = Cells(line);
    if (c.size() >= 2) rows.push_back({n, c[0], c[1]});
  }
  return rows;
}

std::vector<std::string> Split(const std::string& s, const std::string& sep) {
  std::vector<std::string> out;
  size_t at = 0;
  for (size_t i; (i = s.find(sep, at)) != std::string::npos; at = i + sep.size()) out.push_back(Strip(s.substr(at, i - at)));
  out.push_back(Strip(s.substr(at)));
  return out;
}

std::string Unquote(std::string v) {
  if (v.size() >= 2 && (v.front() == '\'' || v.front() == '"') && v.back() == v.front()) v = v.substr(1, v.size() - 2);
  return v;
}

// A default as the docs write it: a YAML list, or its first word ("false
// (true in ...)"), with a size unit ("48 MiB") applied; quotes dropped.
std::string DocValue(const std::string& cell) {
  if (cell.rfind("[", 0) == 0) return cell.substr(0, cell.find(']') + 1);
  const size_t space = cell.find(' ');
  const std::string v = Unquote(cell.substr(0, space));
  if (space != std::string::npos) {
    const std::string unit = cell.substr(space + 1, 3);
    const double scale = unit == "KiB" ? 1024.0 : unit == "MiB" ? 1048576.0 : unit == "GiB" ? 1073741824.0 : 0;
    char* end = nullptr;
    const double x = std::strtod(v.c_str(), &end);
    if (scale > 0 && *end == 0) return std::to_string(int64_t(x * scale));
  }
  return v;
}

bool SameNumber(const std::string& a, const std::string& b) {
  char* e1 = nullptr;
  char* e2 = nullptr;
  const double x = std::strtod(a.c_str(), &e1), y = std::strtod(b.c_str(), &e2);
  return !a.empty() && !b.empty() && *e1 == 0 && *e2 == 0 && std::abs(x - y) <= 1e-12 * std::max(1.0, std::abs(y));
}

bool SameValue(const std::string& doc, const std::string& spec_yaml) {
  const std::string spec = Unquote(spec_yaml);
  if (doc == spec || SameNumber(doc, spec)) return true;
  if (doc.rfind("[", 0) != 0 || spec.rfind("[", 0) != 0) return false;
  const std::vector<std::string> a = Split(doc.substr(1, doc.size() - 2), ","), b = Split(spec.substr(1, spec.size() - 2), ",");
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!SameNumber(a[i], b[i])) return false;
  return true;
}

// "a / b / c" or "a, b": several keys in one row, their defaults alike.
std::string Separator(const std::string& keys) {
  if (keys.find(" / ") != std::string::npos) return " / ";
  if (keys.find(", ") != std::string::npos) return ", ";
  return "";
}

// The comparison itself: a check that cannot fail is no check.
TEST(RumiConfigDocs, TheComparisonSeesAWrongDefault) {
  EXPECT_TRUE(SameValue(DocValue("48 MiB"), "50331648"));
  EXPECT_FALSE(SameValue(DocValue("47 MiB"), "50331648"));
  EXPECT_TRUE(SameValue(DocValue("0.50"), "0.5"));
  EXPECT_FALSE(SameValue(DocValue("0.4"), "0.5"));
  EXPECT_TRUE(SameValue(DocValue(Strip("`huber`")), "'huber'"));
  EXPECT_FALSE(SameValue(DocValue("cauchy"), "'huber'"));
  EXPECT_TRUE(SameValue(DocValue("false (true in configs/daemon.yaml)"), "false"));
  EXPECT_TRUE(SameValue(DocValue("''"), "''"));
  EXPECT_TRUE(SameValue(DocValue("[0, 0, 1]"), "[0.000000, 0.000000, 1.000000]"));
  EXPECT_FALSE(SameValue(DocValue("[0, 1, 0]"), "[0.000000, 0.000000, 1.000000]"));
  EXPECT_EQ(Split("a / b / c", " / "), (std::vector<std::string>{"a", "b", "c"}));
}

TEST(RumiConfigDocs, OptionTablesMatchTheDeclaredDefaults) {
  std::map<std::string, std::map<std::string, std::string>> spec;  // section -> key -> default
  for (const ConfigSectionInfo& s : DescribeRumiConfig(RumiConfig()))
    for (const OptionInfo& o : s.options) spec[s.section][o.key] = o.value;
  const std::vector<std::pair<std::string, std::string>> tables = {
      {"back.md", "back"},    {"daemon.md", "daemon"},   {"dds.md", "dds"},
      {"front.md", "front"},  {"grid.md", "grid"},       {"ipc.md", "ipc"},
      {"manager.md", "manager"}, {"robot_link.md", "source"}, {"view.md", "view"}};
  int checked = 0;
  for (const auto& [doc, section] : tables) {
    ASSERT_TRUE(spec.count(section)) << section;
    const std::vector<Row> rows = OptionTable(doc);
    EXPECT_GE(rows.size(), 3u) << doc << ": no option table found";
    for (const Row& r : rows) {
      const auto& keys = spec[section];
      const std::string sep = Separator(r.key);
      const std::vector<std::string> names = sep.empty() ? std::vector<std::string>{r.key} : Split(r.key, sep);
      const std::vector<std::string> values =
          sep.empty() ? std::vector<std::string>{r.value} : Split(r.value, sep);
      if (names.size() != values.size()) {
        ADD_FAILURE() << "docs/" << doc << ":" << r.line << ": " << names.size() << " keys, " << values.size()
                      << " defaults";
        continue;
      }
      for (size_t i = 0; i < names.size(); ++i) {
        // robot_link.md lists source.link's keys without their prefix.
        const std::string key = section == "source" && !keys.count(names[i]) ? "link." + names[i] : names[i];
        const auto it = keys.find(key);
        if (it == keys.end()) {
          ADD_FAILURE() << "docs/" << doc << ":" << r.line << ": " << section << "." << key
                        << " is not an option (rumi config defaults)";
          continue;
        }
        EXPECT_TRUE(SameValue(DocValue(values[i]), it->second))
            << "docs/" << doc << ":" << r.line << ": " << section << "." << key << " defaults to " << it->second
            << ", the table says " << values[i];
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 100);
}

}  // namespace
}  // namespace rumi
