#include "common/config.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <vector>

namespace rumi {
namespace {

// Message of the ConfigError thrown by f, or "" when none.
template <typename F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_HAS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

TEST(Config, ReadsValuesAndKeepsDefaults) {
  ConfigSection root = LoadConfigString(
      "n: 7\nx: 2.5\nname: orb\nflag: true\nlist: [1, 2, 3]\nfront:\n  levels: 8\n  scale: 1.2\n", "t.yaml");
  int n = 3, missing = 42, levels = 0;
  double x = 0, scale = 0;
  std::string name;
  bool flag = false;
  std::vector<int> list;
  EXPECT_TRUE(root.Read("n", &n));
  EXPECT_TRUE(root.Read("x", &x));
  EXPECT_TRUE(root.Read("name", &name));
  EXPECT_TRUE(root.Read("flag", &flag));
  EXPECT_TRUE(root.Read("list", &list));
  EXPECT_FALSE(root.Read("missing", &missing));
  EXPECT_EQ(n, 7);
  EXPECT_EQ(x, 2.5);
  EXPECT_EQ(name, "orb");
  EXPECT_TRUE(flag);
  EXPECT_EQ(list, (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(missing, 42);
  ConfigSection front = root.Child("front");
  EXPECT_TRUE(front.ReadInRange("levels", &levels, 1, 16));
  EXPECT_TRUE(front.Read("scale", &scale));
  EXPECT_EQ(levels, 8);
  EXPECT_EQ(scale, 1.2);
  EXPECT_EQ(front.FullKey("levels"), "front.levels");
  EXPECT_NO_THROW(root.Finish());
  // Absent sections are empty: everything keeps its default.
  ConfigSection back = root.Child("back");
  int k = 5;
  EXPECT_FALSE(back.Read("k", &k));
  EXPECT_EQ(k, 5);
  EXPECT_NO_THROW(back.Finish());
}

TEST(Config, EmptyConfigIsAllDefaults) {
  ConfigSection empty;
  int v = 1;
  EXPECT_FALSE(empty.Read("v", &v));
  EXPECT_NO_THROW(empty.Finish());
  ConfigSection blank = LoadConfigString("# only a comment\n", "c.yaml");
  EXPECT_NO_THROW(blank.Finish());
}

TEST(Config, UnknownKeyReportedWithFileAndKey) {
  ConfigSection root = LoadConfigString("n: 1\nfornt: {a: 1}\nfront:\n  levles: 3\n  levels: 2\n", "my.yaml");
  int n = 0, levels = 0;
  root.Read("n", &n);
  ConfigSection front = root.Child("front");
  front.Read("levels", &levels);
  const std::string e = ErrorOf([&] { root.Finish(); });
  EXPECT_HAS(e, "my.yaml");
  EXPECT_HAS(e, "'fornt'");
  EXPECT_HAS(e, "'front.levles'");
  EXPECT_EQ(e.find("'front.levels'"), std::string::npos) << e;
  EXPECT_EQ(e.find("'n'"), std::string::npos) << e;
  // A child's Finish checks only its own keys.
  const std::string c = ErrorOf([&] { front.Finish(); });
  EXPECT_HAS(c, "'front.levles'");
  EXPECT_EQ(c.find("fornt"), std::string::npos) << c;
}

TEST(Config, WrongTypeNamesFileKeyAndValue) {
  ConfigSection root = LoadConfigString("n: 3.5\nx: abc\nsec: 4\nflag: maybe\nlist: 7\ns: [1]\n", "w.yaml");
  int n = 0;
  double x = 0;
  bool flag = false;
  std::vector<double> list;
  std::string s;
  std::string e = ErrorOf([&] { root.Read("n", &n); });
  EXPECT_HAS(e, "w.yaml");
  EXPECT_HAS(e, "'n'");
  EXPECT_HAS(e, "wrong type");
  EXPECT_HAS(e, "3.5");
  EXPECT_HAS(ErrorOf([&] { root.Read("x", &x); }), "'x'");
  EXPECT_HAS(ErrorOf([&] { root.Read("flag", &flag); }), "'flag'");
  EXPECT_HAS(ErrorOf([&] { root.Read("list", &list); }), "'list'");
  EXPECT_HAS(ErrorOf([&] { root.Read("s", &s); }), "'s'");
  e = ErrorOf([&] { root.Child("sec"); });
  EXPECT_HAS(e, "'sec'");
  EXPECT_HAS(e, "section");
  // Integers too large for the type are a wrong type, not a wrap-around.
  ConfigSection big = LoadConfigString("n: 99999999999\n", "b.yaml");
  EXPECT_HAS(ErrorOf([&] { big.Read("n", &n); }), "'n'");
  ConfigSection sub = LoadConfigString("a:\n  b:\n    c: x\n", "n.yaml");
  ConfigSection b = sub.Child("a").Child("b");
  EXPECT_HAS(ErrorOf([&] { b.Read("c", &n); }), "'a.b.c'");
}

TEST(Config, OutOfRangeNamesKeyAndBounds) {
  ConfigSection root = LoadConfigString("n: 17\nx: -0.5\ny: .nan\nok: 16\n", "r.yaml");
  int n = 0, ok = 0;
  double x = 0, y = 0;
  std::string e = ErrorOf([&] { root.ReadInRange("n", &n, 1, 16); });
  EXPECT_HAS(e, "r.yaml");
  EXPECT_HAS(e, "'n'");
  EXPECT_HAS(e, "out of range");
  EXPECT_HAS(e, "16");
  EXPECT_HAS(ErrorOf([&] { root.ReadInRange("x", &x, 0.0, 1.0); }), "'x'");
  EXPECT_HAS(ErrorOf([&] { root.ReadInRange("y", &y, 0.0, 1.0); }), "'y'");  // NaN is not in range
  EXPECT_EQ(ErrorOf([&] { root.ReadInRange("ok", &ok, 1, 16); }), "");  // bounds inclusive
  EXPECT_EQ(ok, 16);
}

TEST(Config, EmptyValueIsAnError) {
  ConfigSection root = LoadConfigString("n:\nsec:\n", "e.yaml");
  int n = 4;
  EXPECT_HAS(ErrorOf([&] { root.Read("n", &n); }), "'n'");
  EXPECT_NO_THROW(root.Child("sec"));  // an empty section is fine
}

TEST(Config, MalformedYamlNamesLine) {
  std::string e = ErrorOf([] { LoadConfigString("a: 1\nb: [1, 2\nc: 3\n", "m.yaml"); });
  EXPECT_HAS(e, "m.yaml");
  EXPECT_HAS(e, "malformed");
  EXPECT_HAS(e, "line 3");
  e = ErrorOf([] { LoadConfigString("a: 1\n  b: 2\n", "m2.yaml"); });
  EXPECT_HAS(e, "m2.yaml");
  EXPECT_HAS(e, "line 2");
  e = ErrorOf([] { LoadConfigString("- 1\n- 2\n", "list.yaml"); });
  EXPECT_HAS(e, "list.yaml");
  EXPECT_HAS(e, "map");
}

// 478 bytes that stand for 10^9 nodes: refused at once, naming the line.
TEST(Config, AliasesAreRefusedBeforeTheTreeIsWalked) {
  std::string bomb = "a: &a [x, x, x, x, x, x, x, x, x, x]\n";
  for (char c = 'b'; c <= 'i'; ++c) {
    const std::string p(1, char(c - 1));
    bomb += std::string(1, c) + ": &" + c + " [*" + p + ", *" + p + ", *" + p + ", *" + p + ", *" + p + ", *" + p +
            ", *" + p + ", *" + p + ", *" + p + ", *" + p + "]\n";
  }
  const std::string e = ErrorOf([&] { LoadConfigString(bomb, "bomb.yaml"); });
  EXPECT_HAS(e, "bomb.yaml");
  EXPECT_HAS(e, "line 2");
  EXPECT_HAS(e, "aliases");
  // One alias is refused too; anchors alone are harmless.
  EXPECT_HAS(ErrorOf([] { LoadConfigString("a: &x 1\nb: *x\n", "one.yaml"); }), "aliases");
  EXPECT_NO_THROW(LoadConfigString("a: &x 1\nb: 2\n", "anchor.yaml"));
}

TEST(Config, ANonRegularFileIsNoConfig) {
  const std::string e = ErrorOf([] { LoadConfigFile("/dev/zero"); });
  EXPECT_HAS(e, "/dev/zero");
  EXPECT_HAS(e, "not a regular file");
}

TEST(Config, DuplicateKeyRejected) {
  // yaml-cpp alone would silently keep the first value.
  std::string e = ErrorOf([] { LoadConfigString("a: 1\nb: 2\na: 3\n", "d.yaml"); });
  EXPECT_HAS(e, "d.yaml");
  EXPECT_HAS(e, "line 3");
  EXPECT_HAS(e, "duplicate key 'a'");
  e = ErrorOf([] { LoadConfigString("front:\n  x: 1\n  x: 2\n", "d2.yaml"); });
  EXPECT_HAS(e, "'front.x'");
}

TEST(Config, MissingFile) {
  const std::string e = ErrorOf([] { LoadConfigFile("/nonexistent/rumi/config.yaml"); });
  EXPECT_HAS(e, "/nonexistent/rumi/config.yaml");
}

TEST(Config, LoadsFileAndNamesItInErrors) {
  const std::string path = ::testing::TempDir() + "/rumi_config_test_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(path) << "n: 2\nbogus: 1\n";
  ConfigSection root = LoadConfigFile(path);
  int n = 0;
  root.Read("n", &n);
  EXPECT_EQ(n, 2);
  const std::string e = ErrorOf([&] { root.Finish(); });
  EXPECT_HAS(e, path);
  EXPECT_HAS(e, "'bogus'");
  std::remove(path.c_str());
}

struct FooOptions {
  int n = 3;
  bool Check(std::string* why) const {
    if (n % 2 == 0) {
      if (why) *why = "n must be odd";
      return false;
    }
    return true;
  }
};

TEST(Config, CheckOptionsNamesSection) {
  ConfigSection root = LoadConfigString("foo: {n: 4}\n", "o.yaml");
  ConfigSection foo = root.Child("foo");
  FooOptions o;
  foo.Read("n", &o.n);
  const std::string e = ErrorOf([&] { CheckOptions(o, root, "foo"); });
  EXPECT_HAS(e, "o.yaml");
  EXPECT_HAS(e, "'foo'");
  EXPECT_HAS(e, "n must be odd");
}

}  // namespace
}  // namespace rumi
