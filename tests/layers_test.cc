// The layers point down only (docs/ARCHITECTURE.md): common -> ipc ->
// front / back / manager -> apps -> tests. A file may include from its own
// top-level folder and from the layers below it, never from a layer above or
// from a sibling (front, back and manager do not include each other). Read
// from the sources' own #include lines.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace rumi {
namespace {
namespace fs = std::filesystem;

const std::map<std::string, int>& Layers() {
  // firmware/ is the robot's own code and the link's wire protocol: it
  // includes nothing of the ground station.
  static const std::map<std::string, int> m = {{"common", 0}, {"firmware", 0}, {"ipc", 1},  {"front", 2},
                                               {"back", 2},   {"manager", 2},  {"apps", 3}, {"tests", 4}};
  return m;
}

// The include lines of `text` (a file in top-level folder `top`) that point
// up or sideways, as "LINE: #include ...".
std::vector<std::string> UpwardIncludes(const std::string& top, const std::string& text) {
  static const std::regex include(R"(^\s*#\s*include\s*"([a-z_0-9]+)/)");
  std::vector<std::string> out;
  const int own = Layers().at(top);
  std::istringstream in(text);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    std::smatch m;
    if (!std::regex_search(line, m, include)) continue;
    const auto to = Layers().find(m[1].str());
    if (to == Layers().end() || to->first == top) continue;
    if (to->second >= own) out.push_back(std::to_string(n) + ": " + line);
  }
  return out;
}

TEST(Layers, TheCheckSeesAnUpwardOrSidewaysInclude) {
  EXPECT_EQ(UpwardIncludes("back", "#include \"common/timestamp.h\"\n#include \"ipc/dds/map_server.h\"\n").size(), 0u);
  EXPECT_EQ(UpwardIncludes("back", "#include <vector>\n#include \"manager/dds/x.h\"\n"),
            std::vector<std::string>{"2: #include \"manager/dds/x.h\""});
  EXPECT_EQ(UpwardIncludes("common", "  #  include \"apps/config/rumi_config.h\"").size(), 1u);
  EXPECT_EQ(UpwardIncludes("ipc", "#include \"front/sampler.h\"").size(), 1u);
  EXPECT_EQ(UpwardIncludes("apps", "#include \"manager/merge.h\"\n#include \"apps/cli/commands.h\"").size(), 0u);
}

TEST(Layers, NoFileIncludesUpOrSideways) {
  const fs::path root = RUMI_SOURCE_DIR;
  size_t files = 0;
  for (const auto& layer : Layers()) {
    ASSERT_TRUE(fs::is_directory(root / layer.first)) << (root / layer.first);
    for (const auto& e : fs::recursive_directory_iterator(root / layer.first)) {
      const std::string ext = e.path().extension().string();
      if (!e.is_regular_file() || (ext != ".h" && ext != ".cc" && ext != ".c")) continue;
      std::ifstream in(e.path());
      const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      ++files;
      for (const std::string& bad : UpwardIncludes(layer.first, text))
        ADD_FAILURE() << fs::relative(e.path(), root).string() << ":" << bad;
    }
  }
  EXPECT_GT(files, 300u);  // the tree was read
}

// Test support (common/testing/, manager/testing/, ...) is for tests and
// benchmarks only: a process that included it would carry a test fixture.
bool IsTestCode(const fs::path& rel) {
  const std::string name = rel.stem().string();
  if (name.size() > 5 && name.compare(name.size() - 5, 5, "_test") == 0) return true;
  if (name.size() > 10 && name.compare(name.size() - 10, 10, "_benchmark") == 0) return true;
  for (const auto& part : rel.parent_path())
    if (part == "testing" || part == "tests") return true;
  return false;
}

TEST(Layers, OnlyTestsAndBenchmarksIncludeTestSupport) {
  EXPECT_TRUE(IsTestCode("front/matcher_test.cc"));
  EXPECT_TRUE(IsTestCode("manager/merge_benchmark.cc"));
  EXPECT_TRUE(IsTestCode("manager/testing/synthetic_walk.cc"));
  EXPECT_TRUE(IsTestCode("tests/rumi_cli_util.h"));
  EXPECT_FALSE(IsTestCode("manager/merge.cc"));
  EXPECT_FALSE(IsTestCode("apps/cli/synth_command.cc"));
  static const std::regex testing_include(R"(^\s*#\s*include\s*"[a-z_0-9/]*/testing/)");
  const fs::path root = RUMI_SOURCE_DIR;
  for (const auto& layer : Layers()) {
    for (const auto& e : fs::recursive_directory_iterator(root / layer.first)) {
      const std::string ext = e.path().extension().string();
      if (!e.is_regular_file() || (ext != ".h" && ext != ".cc" && ext != ".c")) continue;
      const fs::path rel = fs::relative(e.path(), root);
      if (IsTestCode(rel)) continue;
      std::ifstream in(e.path());
      std::string line;
      for (int n = 1; std::getline(in, line); ++n)
        if (std::regex_search(line, testing_include)) ADD_FAILURE() << rel.string() << ":" << n << ": " << line;
    }
  }
}

}  // namespace
}  // namespace rumi
