#include "common/option_spec.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rumi {
namespace {

struct Inner {
  int n = 2;
  static const OptionSpec<Inner>& Spec() {
    static const auto* spec = [] {
      auto* s = new OptionSpec<Inner>("inner");
      s->Number("n", &Inner::n, AtLeast(1), AtMost(9), "a count");
      return s;
    }();
    return *spec;
  }
};

enum class Mode { kA, kB };

struct Demo {
  double ratio = 0.5;
  int64_t big = 7;
  bool flag = false;
  std::string name = "x";
  std::string kind = "huber";
  Mode mode = Mode::kA;
  Inner inner;
  int lo = 1, hi = 3;
  static const OptionSpec<Demo>& Spec() {
    static const auto* spec = [] {
      auto* s = new OptionSpec<Demo>("demo");
      s->Number("ratio", &Demo::ratio, Above(0.0), Below(1.0), "open interval");
      s->Number<int64_t>("big", &Demo::big, AtLeast<int64_t>(0), Unbounded<int64_t>(), "no upper bound");
      s->Flag("flag", &Demo::flag, "a switch");
      s->Text("name", &Demo::name, "must be set", true);
      s->Choice("kind", &Demo::kind, {"huber", "cauchy"}, "loss");
      s->Enum("mode", &Demo::mode, {{"a", Mode::kA}, {"b", Mode::kB}}, "mode");
      s->Section("inner", &Demo::inner, Inner::Spec());
      s->Number("lo", &Demo::lo, AtLeast(0), AtMost(100), "lower");
      s->Number("hi", &Demo::hi, AtLeast(0), AtMost(100), "upper");
      s->Rule("lo must be <= hi", [](const Demo& d) { return d.lo <= d.hi; });
      return s;
    }();
    return *spec;
  }
};

std::string ReadError(const std::string& yaml, Demo* d) {
  try {
    ConfigSection root = LoadConfigString(yaml, "d.yaml");
    ConfigSection s = root.Child("demo");
    ReadOptions(s, d);
    root.Finish();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(OptionSpec, ReadsEveryKindOfOption) {
  Demo d;
  ASSERT_EQ(ReadError("demo: {ratio: 0.25, big: 99, flag: true, name: y, kind: cauchy, mode: b, inner: {n: 5}, "
                      "lo: 4, hi: 4}\n",
                      &d),
            "");
  EXPECT_EQ(d.ratio, 0.25);
  EXPECT_EQ(d.big, 99);
  EXPECT_TRUE(d.flag);
  EXPECT_EQ(d.name, "y");
  EXPECT_EQ(d.kind, "cauchy");
  EXPECT_EQ(d.mode, Mode::kB);
  EXPECT_EQ(d.inner.n, 5);
  Demo defaults;
  EXPECT_EQ(ReadError("demo: {}\n", &defaults), "");  // absent keys keep their defaults
  EXPECT_EQ(defaults.ratio, 0.5);
}

TEST(OptionSpec, ReaderAndCheckRefuseTheSameValuesNamingTheKey) {
  struct Case {
    std::string yaml, key, reason;
  };
  for (const Case& c : std::vector<Case>{{"ratio: 1.0", "demo.ratio", "outside (0, 1)"},
                                         {"ratio: 0", "demo.ratio", "outside (0, 1)"},
                                         {"ratio: .nan", "demo.ratio", "outside (0, 1)"},
                                         {"big: -1", "demo.big", "outside [0, inf]"},
                                         {"name: ''", "demo.name", "must not be empty"},
                                         {"kind: l2", "demo.kind", "not one of huber|cauchy"},
                                         {"mode: c", "demo.mode", "not one of a|b"},
                                         {"inner: {n: 10}", "demo.inner.n", "outside [1, 9]"},
                                         {"flag: maybe", "demo.flag", "wrong type"}}) {
    Demo d;
    const std::string e = ReadError("demo: {" + c.yaml + "}\n", &d);
    EXPECT_NE(e.find("d.yaml: key '" + c.key + "'"), std::string::npos) << c.yaml << " -> " << e;
    EXPECT_NE(e.find(c.reason), std::string::npos) << c.yaml << " -> " << e;
  }
  Demo d;
  d.ratio = 1.0;
  std::string why;
  EXPECT_FALSE(Demo::Spec().Check(d, &why));
  EXPECT_EQ(why, "ratio: value 1 is outside (0, 1)");
  d = Demo();
  d.inner.n = 0;
  EXPECT_FALSE(Demo::Spec().Check(d, &why));
  EXPECT_EQ(why, "inner.n: value 0 is outside [1, 9]");
}

TEST(OptionSpec, RulesAcrossFieldsAndUnknownKeys) {
  Demo d;
  std::string e = ReadError("demo: {lo: 5, hi: 4}\n", &d);
  EXPECT_NE(e.find("section 'demo': lo must be <= hi"), std::string::npos) << e;
  Demo fresh;
  e = ReadError("demo: {ratoi: 0.2}\n", &fresh);
  EXPECT_NE(e.find("unknown key: 'demo.ratoi'"), std::string::npos) << e;
  e = ReadError("demo: {inner: {m: 1}}\n", &fresh);
  EXPECT_NE(e.find("'demo.inner.m'"), std::string::npos) << e;
}

TEST(OptionSpec, DescribeListsEveryKeyWithDefaultAndRange) {
  const std::vector<OptionInfo> info = Demo::Spec().Describe(Demo());
  std::vector<std::string> keys;
  for (const OptionInfo& i : info) keys.push_back(i.key);
  EXPECT_EQ(keys, (std::vector<std::string>{"ratio", "big", "flag", "name", "kind", "mode", "inner.n", "lo", "hi"}));
  EXPECT_EQ(info[0].value, "0.5");
  EXPECT_EQ(info[0].range, "(0, 1)");
  EXPECT_EQ(info[3].value, "'x'");
  EXPECT_EQ(info[5].value, "a");
  EXPECT_EQ(info[6].range, "[1, 9]");
  EXPECT_EQ(Demo::Spec().Keys(), keys);
}

TEST(OptionSpec, ADuplicateDeclarationIsAProgrammingError) {
  OptionSpec<Demo> s("demo");
  s.Flag("flag", &Demo::flag, "");
  EXPECT_THROW(s.Flag("flag", &Demo::flag, ""), std::logic_error);
}

}  // namespace
}  // namespace rumi
