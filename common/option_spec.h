#pragma once
// Every option of a FooOptions struct is declared once, in FooOptions::Spec():
// its YAML key, the field, its range and a one-line help. The YAML reader,
// the range check (FooOptions::Check) and `rumi config defaults` all come
// from that one declaration, so a key, its range and its check cannot drift
// apart (COLMAP's option manager does the same).
//
//   const OptionSpec<FooOptions>& FooOptions::Spec() {
//     static const auto* spec = [] {
//       auto* s = new OptionSpec<FooOptions>("foo");
//       s->Number("n", &FooOptions::n, AtLeast(1), AtMost(64), "threads");
//       s->Rule("n_max must be >= n", [](const FooOptions& o) { return o.n_max >= o.n; });
//       return s;
//     }();
//     return *spec;
//   }
//   bool FooOptions::Check(std::string* why) const { return Spec().Check(*this, why); }
//
// ReadOptions(section, &foo) then reads every declared key present (absent
// keys keep their defaults), rejects a wrong type or an out-of-range value
// naming file and key, and runs the rules. Unknown keys are reported by
// ConfigSection::Finish on the root.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "common/config.h"

namespace rumi {

// One side of a numeric range: none, inclusive or exclusive.
template <typename T>
struct Limit {
  enum class Kind { kNone, kInclusive, kExclusive } kind = Kind::kNone;
  T value{};
};
template <typename T> Limit<T> AtLeast(T v) { return {Limit<T>::Kind::kInclusive, v}; }
template <typename T> Limit<T> Above(T v) { return {Limit<T>::Kind::kExclusive, v}; }
template <typename T> Limit<T> AtMost(T v) { return {Limit<T>::Kind::kInclusive, v}; }
template <typename T> Limit<T> Below(T v) { return {Limit<T>::Kind::kExclusive, v}; }
template <typename T> Limit<T> Unbounded() { return {}; }

// What `rumi config defaults` prints for one option.
struct OptionInfo {
  std::string key;      // dotted, relative to the spec's section
  std::string value;    // the default, as YAML
  std::string range;    // "[1, 64]", "(0, 1]", "huber|cauchy", "true|false", ""
  std::string help;
};

namespace option_detail {
template <typename T>
std::string Show(const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return v ? "true" : "false";
  } else if constexpr (std::is_floating_point_v<T>) {
    std::ostringstream s;
    s.precision(12);
    s << v;
    return s.str();
  } else if constexpr (std::is_arithmetic_v<T>) {
    return std::to_string(v);
  } else {
    return "'" + v + "'";
  }
}
template <typename T>
std::string RangeText(const Limit<T>& lo, const Limit<T>& hi) {
  if (lo.kind == Limit<T>::Kind::kNone && hi.kind == Limit<T>::Kind::kNone) return "";
  std::string s = lo.kind == Limit<T>::Kind::kExclusive ? "(" : "[";
  s += lo.kind == Limit<T>::Kind::kNone ? "-inf" : Show(lo.value);
  s += ", ";
  s += hi.kind == Limit<T>::Kind::kNone ? "inf" : Show(hi.value);
  s += hi.kind == Limit<T>::Kind::kExclusive ? ")" : "]";
  return s;
}
// Written so that NaN is outside every range.
template <typename T>
bool InRange(T v, const Limit<T>& lo, const Limit<T>& hi) {
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(v)) return false;
  }
  using K = typename Limit<T>::Kind;
  if (lo.kind == K::kInclusive && !(v >= lo.value)) return false;
  if (lo.kind == K::kExclusive && !(v > lo.value)) return false;
  if (hi.kind == K::kInclusive && !(v <= hi.value)) return false;
  if (hi.kind == K::kExclusive && !(v < hi.value)) return false;
  return true;
}
}  // namespace option_detail

template <typename O>
class OptionSpec {
 public:
  // Checks o, filling *why with "<key> ..." for the first problem.
  using CheckFn = std::function<bool(const O&, std::string*)>;
  // Reads the key from the section into o; throws ConfigError.
  using ReadFn = std::function<void(ConfigSection&, O*)>;

  explicit OptionSpec(std::string section) : section_(std::move(section)) {}
  const std::string& section() const { return section_; }

  // int, int64_t, uint32_t, double within [lo, hi] (each side optional).
  template <typename T>
  OptionSpec& Number(const std::string& key, T O::*field, Limit<T> lo, Limit<T> hi, std::string help) {
    static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>, "Number takes numbers");
    const std::string range = option_detail::RangeText(lo, hi);
    auto problem = [field, lo, hi, range](const O& o) -> std::string {
      if (option_detail::InRange(o.*field, lo, hi)) return "";
      return "value " + option_detail::Show(o.*field) +
             (range.empty() ? " is not a finite number" : " is outside " + range);
    };
    return AddChecked({key, "", range, std::move(help)},
                      [key, field](ConfigSection& s, O* o) { return s.Read(key, &(o->*field)); }, problem,
                      [field](const O& o) { return option_detail::Show(o.*field); });
  }

  OptionSpec& Flag(const std::string& key, bool O::*field, std::string help) {
    auto read = [key, field](ConfigSection& s, O* o) { s.Read(key, &(o->*field)); };
    return Add({key, "", "true|false", std::move(help)}, read, nullptr,
               [field](const O& o) { return option_detail::Show(o.*field); });
  }

  // A string; `non_empty` refuses "".
  OptionSpec& Text(const std::string& key, std::string O::*field, std::string help, bool non_empty = false) {
    auto problem = [field, non_empty](const O& o) -> std::string {
      return non_empty && (o.*field).empty() ? "must not be empty" : "";
    };
    return AddChecked({key, "", non_empty ? "non-empty" : "", std::move(help)},
                      [key, field](ConfigSection& s, O* o) { return s.Read(key, &(o->*field)); }, problem,
                      [field](const O& o) { return option_detail::Show(o.*field); });
  }

  // A string checked by `problem` ("" when fine); `range` says what it accepts.
  OptionSpec& Text(const std::string& key, std::string O::*field, std::string help, std::string range,
                   std::function<std::string(const std::string&)> problem) {
    return AddChecked({key, "", std::move(range), std::move(help)},
                      [key, field](ConfigSection& s, O* o) { return s.Read(key, &(o->*field)); },
                      [field, problem](const O& o) { return problem(o.*field); },
                      [field](const O& o) { return option_detail::Show(o.*field); });
  }

  // A string that must be one of `choices`.
  OptionSpec& Choice(const std::string& key, std::string O::*field, std::vector<std::string> choices,
                     std::string help) {
    std::string range;
    for (const auto& c : choices) range += (range.empty() ? "" : "|") + c;
    auto problem = [field, choices, range](const O& o) -> std::string {
      for (const auto& c : choices)
        if (o.*field == c) return "";
      return "'" + o.*field + "' is not one of " + range;
    };
    return AddChecked({key, "", range, std::move(help)},
                      [key, field](ConfigSection& s, O* o) { return s.Read(key, &(o->*field)); }, problem,
                      [field](const O& o) { return option_detail::Show(o.*field); });
  }

  // An enum stored as its name in YAML: names[i] <-> values[i].
  template <typename E>
  OptionSpec& Enum(const std::string& key, E O::*field, std::vector<std::pair<std::string, E>> names,
                   std::string help) {
    std::string range;
    for (const auto& n : names) range += (range.empty() ? "" : "|") + n.first;
    auto read = [key, field, names, range](ConfigSection& s, O* o) {
      std::string v;
      if (!s.Read(key, &v)) return;
      for (const auto& n : names) {
        if (n.first == v) {
          o->*field = n.second;
          return;
        }
      }
      s.Fail(key, "'" + v + "' is not one of " + range);
    };
    auto show = [field, names](const O& o) {
      for (const auto& n : names)
        if (n.second == o.*field) return n.first;
      return std::string("?");
    };
    return Add({key, "", range, std::move(help)}, read, nullptr, show);
  }

  // A nested section with its own spec (YAML `key:` map).
  template <typename Sub>
  OptionSpec& Section(const std::string& key, Sub O::*field, const OptionSpec<Sub>& sub) {
    const OptionSpec<Sub>* sp = &sub;
    auto read = [key, field, sp](ConfigSection& s, O* o) {
      ConfigSection child = s.Child(key);
      sp->Read(child, &(o->*field));
    };
    auto check = [key, field, sp](const O& o, std::string* why) {
      std::string w;
      if (sp->Check(o.*field, &w)) return true;
      if (why) *why = key + "." + w;
      return false;
    };
    auto nested = [key, field, sp](const O& o) {
      std::vector<OptionInfo> v = sp->Describe(o.*field);
      for (OptionInfo& i : v) i.key = key + "." + i.key;
      return v;
    };
    return Add({key, "", "", ""}, read, check, nullptr, nested);
  }

  // A member struct whose keys sit in this same section (no `key:` level).
  template <typename Sub>
  OptionSpec& Inline(Sub O::*field, const OptionSpec<Sub>& sub) {
    const OptionSpec<Sub>* sp = &sub;
    auto read = [field, sp](ConfigSection& s, O* o) { sp->Read(s, &(o->*field)); };
    auto check = [field, sp](const O& o, std::string* why) { return sp->Check(o.*field, why); };
    auto nested = [field, sp](const O& o) { return sp->Describe(o.*field); };
    return Add({"(" + sub.section() + ")", "", "", ""}, read, check, nullptr, nested);
  }

  // Anything else (a pose, a list): its own reader and checker.
  OptionSpec& Custom(OptionInfo info, ReadFn read, CheckFn check, std::function<std::string(const O&)> show) {
    return Add(std::move(info), std::move(read), std::move(check), std::move(show));
  }

  // A check across fields, stated as the message shown when it fails.
  OptionSpec& Rule(std::string message, std::function<bool(const O&)> holds) {
    rules_.push_back([message, holds](const O& o) { return holds(o) ? std::string() : message; });
    return *this;
  }
  // The same with a message built from the values: "" when o is fine.
  OptionSpec& Rule(std::function<std::string(const O&)> problem) {
    rules_.push_back(std::move(problem));
    return *this;
  }

  // Reads every declared key present in s, then runs the rules. Throws
  // ConfigError naming the file and key.
  void Read(ConfigSection& s, O* o) const {
    for (const Entry& e : entries_) e.read(s, o);
    std::string why;
    if (!CheckRules(*o, &why)) {
      std::string where = s.FullKey("");
      if (!where.empty() && where.back() == '.') where.pop_back();
      throw ConfigError(s.file() + ": section '" + (where.empty() ? section_ : where) + "': " + why);
    }
  }

  // Every range and rule; *why names the key ("pair_ratio = 1.5 is outside (0, 1]").
  bool Check(const O& o, std::string* why = nullptr) const {
    for (const Entry& e : entries_)
      if (e.check && !e.check(o, why)) return false;
    return CheckRules(o, why);
  }

  // The declared options with o's values (defaults: Describe(O())), nested
  // sections as "section.key".
  std::vector<OptionInfo> Describe(const O& o) const {
    std::vector<OptionInfo> out;
    for (const Entry& e : entries_) {
      if (e.nested) {
        for (OptionInfo& i : e.nested(o)) out.push_back(std::move(i));
        continue;
      }
      OptionInfo i = e.info;
      i.value = e.show(o);
      out.push_back(i);
    }
    return out;
  }
  // Every key, nested ones dotted ("orb.num_levels").
  std::vector<std::string> Keys() const {
    std::vector<std::string> k;
    for (const OptionInfo& i : Describe(O())) k.push_back(i.key);
    return k;
  }

 private:
  struct Entry {
    OptionInfo info;
    ReadFn read;
    CheckFn check;  // may be empty (no range)
    std::function<std::string(const O&)> show;  // empty for sections
    std::function<std::vector<OptionInfo>(const O&)> nested;  // sections only
  };
  OptionSpec& Add(OptionInfo info, ReadFn read, CheckFn check, std::function<std::string(const O&)> show,
                  std::function<std::vector<OptionInfo>(const O&)> nested = nullptr) {
    for (const Entry& e : entries_)
      if (e.info.key == info.key) throw std::logic_error("option '" + info.key + "' declared twice in " + section_);
    entries_.push_back({std::move(info), std::move(read), std::move(check), std::move(show), std::move(nested)});
    return *this;
  }
  // An option whose value must pass `problem` ("" when fine): the reader
  // fails with it naming the key, Check() with "<key>: <problem>".
  OptionSpec& AddChecked(OptionInfo info, std::function<bool(ConfigSection&, O*)> read_value,
                         std::function<std::string(const O&)> problem, std::function<std::string(const O&)> show) {
    const std::string key = info.key;
    auto read = [key, read_value, problem](ConfigSection& s, O* o) {
      if (!read_value(s, o)) return;
      const std::string p = problem(*o);
      if (!p.empty()) s.Fail(key, p);
    };
    auto check = [key, problem](const O& o, std::string* why) {
      const std::string p = problem(o);
      if (p.empty()) return true;
      if (why) *why = key + ": " + p;
      return false;
    };
    return Add(std::move(info), read, check, std::move(show));
  }
  bool CheckRules(const O& o, std::string* why) const {
    for (const auto& rule : rules_) {
      const std::string problem = rule(o);
      if (problem.empty()) continue;
      if (why) *why = problem;
      return false;
    }
    return true;
  }

  std::string section_;
  std::vector<Entry> entries_;
  std::vector<std::function<std::string(const O&)>> rules_;
};

// Reads any options struct that declares a Spec().
template <typename O>
auto ReadOptions(ConfigSection& s, O* o) -> decltype(O::Spec(), void()) {
  O::Spec().Read(s, o);
}

}  // namespace rumi
