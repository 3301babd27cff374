#include "common/eval_table.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>

#include "common/run_metrics.h"

namespace rumi {
namespace {

double Number(const nlohmann::json& j, const std::string& key, const std::string& source) {
  if (!j.contains(key)) throw std::runtime_error(source + ": missing key '" + key + "'");
  if (!j[key].is_number()) throw std::runtime_error(source + ": key '" + key + "' is not a number");
  return j[key].get<double>();
}

std::optional<double> NumberOrNull(const nlohmann::json& j, const std::string& key,
                                   const std::string& source) {
  if (!j.contains(key)) throw std::runtime_error(source + ": missing key '" + key + "'");
  if (j[key].is_null()) return std::nullopt;
  return Number(j, key, source);
}

struct Stat {
  double mean = 0, std = 0;
  int n = 0;
};

Stat Summarize(const std::vector<double>& v) {
  Stat s;
  s.n = static_cast<int>(v.size());
  if (v.empty()) return s;
  for (double x : v) s.mean += x;
  s.mean /= v.size();
  for (double x : v) s.std += (x - s.mean) * (x - s.mean);
  s.std = v.size() > 1 ? std::sqrt(s.std / (v.size() - 1)) : 0.0;
  return s;
}

std::string Fmt(const Stat& s, int decimals, double scale = 1.0) {
  char buf[64];
  if (s.n > 1) {
    std::snprintf(buf, sizeof(buf), "%.*f ± %.*f", decimals, s.mean * scale, decimals, s.std * scale);
  } else {
    std::snprintf(buf, sizeof(buf), "%.*f", decimals, s.mean * scale);
  }
  return buf;
}

using Getter = std::function<void(const RunMetrics&, double*, std::optional<double>*, double*)>;

// Rate (%), RMSE and frames cells of one method for one row.
std::vector<std::string> Cells(const TableRow& row, const Getter& get, const EvalTableOptions& o) {
  std::vector<double> rates, rmses, frames;
  bool rmse_missing = false;
  for (const auto& r : row.runs) {
    double rate = 0, fr = 0;
    std::optional<double> rmse;
    get(r, &rate, &rmse, &fr);
    rates.push_back(rate);
    frames.push_back(fr);
    if (rmse) rmses.push_back(*rmse); else rmse_missing = true;
  }
  const Stat rate = Summarize(rates);
  // Below min_rate_for_rmse the error covers too little of the sequence to
  // compare with other rows: shown in parentheses, not hidden.
  std::string rmse_cell = "-";
  if (!rmse_missing && !rmses.empty()) {
    rmse_cell = Fmt(Summarize(rmses), 3);
    if (rate.mean < o.min_rate_for_rmse) rmse_cell = "(" + rmse_cell + ")";
  }
  return {Fmt(rate, 1, 100.0), rmse_cell, Fmt(Summarize(frames), 0)};
}

const std::vector<std::pair<std::string, Getter>>& Methods() {
  static const std::vector<std::pair<std::string, Getter>> m = {
      {"rumi with PO", [](const RunMetrics& r, double* a, std::optional<double>* b, double* c) {
         *a = r.po_rate; *b = r.po_rmse; *c = r.po_frames; }},
      {"rumi", [](const RunMetrics& r, double* a, std::optional<double>* b, double* c) {
         *a = r.merged_rate; *b = r.merged_rmse; *c = r.merged_frames; }},
      {"front only", [](const RunMetrics& r, double* a, std::optional<double>* b, double* c) {
         *a = r.front_rate; *b = r.front_rmse; *c = r.front_frames; }},
  };
  return m;
}

// "accepted / rejected / harmful" over the runs; "-" when a run has no audit.
std::string MergeCell(const TableRow& row) {
  int acc = 0, rej = 0, harm = 0;
  for (const auto& r : row.runs) {
    if (!r.merges_rejected || !r.merges_harmful) return "-";
    acc += int(r.merges);
    rej += *r.merges_rejected;
    harm += *r.merges_harmful;
  }
  return std::to_string(acc) + " / " + std::to_string(rej) + " / " + std::to_string(harm);
}

// "p50 / p95 / max (merged of losses)" in seconds over the losses of every
// run; "-" when a run has no loss-to-merge times.
std::string LossToMergeCell(const TableRow& row) {
  std::vector<double> v;
  size_t losses = 0;
  for (const auto& r : row.runs) {
    if (!r.loss_to_merge_s) return "-";
    losses += r.loss_to_merge_s->size();
    for (const auto& s : *r.loss_to_merge_s)
      if (s) v.push_back(*s);
  }
  if (losses == 0) return "no loss";
  const std::string counts = " (" + std::to_string(v.size()) + " of " + std::to_string(losses) + ")";
  if (v.empty()) return "-" + counts;
  char buf[96];
  std::snprintf(buf, sizeof(buf), "%.0f / %.0f / %.0f", *Median(v), *PercentileNearestRank(v, 95),
                *std::max_element(v.begin(), v.end()));
  return buf + counts;
}

}  // namespace

bool EvalTableOptions::Check(std::string* why) const {
  if (min_rate_for_rmse < 0 || min_rate_for_rmse > 1) {
    if (why) *why = "min_rate_for_rmse must be in [0, 1]";
    return false;
  }
  return true;
}

RunMetrics ParseRunMetrics(const std::string& json_text, const std::string& source) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(source + ": not valid JSON: " + e.what());
  }
  if (!j.is_object()) throw std::runtime_error(source + ": expected a JSON object");
  RunMetrics m;
  m.sequence = j.contains("sequence") && j["sequence"].is_string() ? j["sequence"].get<std::string>() : "";
  m.front_rate = Number(j, "front_tracking_rate_time", source);
  m.merged_rate = Number(j, "merged_tracking_rate_time", source);
  m.front_rmse = NumberOrNull(j, "front_ate_rmse", source);
  m.merged_rmse = NumberOrNull(j, "merged_ate_rmse", source);
  m.front_frames = Number(j, "front_saved_frames", source);
  m.merged_frames = Number(j, "saved_frames", source);
  m.po_frames = Number(j, "saved_frames_postculled", source);
  m.po_rate = j.contains("postculled_tracking_rate_time") ? Number(j, "postculled_tracking_rate_time", source)
                                                          : m.merged_rate;
  m.po_rmse = j.contains("postculled_ate_rmse") ? NumberOrNull(j, "postculled_ate_rmse", source)
                                                : m.merged_rmse;
  m.merges = j.contains("merges") ? Number(j, "merges", source) : 0;
  if (j.contains("merges_rejected")) m.merges_rejected = int(Number(j, "merges_rejected", source));
  if (j.contains("merges_harmful")) m.merges_harmful = int(Number(j, "merges_harmful", source));
  if (j.contains("loss_to_merge")) {
    const auto& a = j["loss_to_merge"];
    if (!a.is_array()) throw std::runtime_error(source + ": key 'loss_to_merge' is not an array");
    m.loss_to_merge_s.emplace();
    for (const auto& l : a) {
      if (!l.is_object() || !l.contains("seconds") || !(l["seconds"].is_null() || l["seconds"].is_number()))
        throw std::runtime_error(source + ": loss_to_merge: each entry needs 'seconds' (a number or null)");
      m.loss_to_merge_s->push_back(l["seconds"].is_null() ? std::nullopt
                                                          : std::optional<double>(l["seconds"].get<double>()));
    }
  }
  if (j.contains("warnings") && j["warnings"].is_array())
    for (const auto& w : j["warnings"])
      if (w.is_string()) m.warnings.push_back(w.get<std::string>());
  return m;
}

std::string FormatEvalTableMarkdown(const std::vector<TableRow>& rows, const EvalTableOptions& o) {
  std::string out = "| Sequence |";
  std::string sep = "|---|";
  for (const auto& m : Methods()) {
    out += " " + m.first + " Rate (%) | " + m.first + " RMSE | " + m.first + " Frames |";
    sep += "---:|---:|---:|";
  }
  out += " Merges acc / rej / harmful | Loss to merge s p50 / p95 / max |";
  sep += "---:|---:|";
  out += "\n" + sep + "\n";
  bool partial = false;  // an RMSE in parentheses
  for (const auto& row : rows) {
    out += "| " + row.sequence + " |";
    for (const auto& m : Methods()) {
      for (const auto& c : Cells(row, m.second, o)) {
        out += " " + c + " |";
        partial |= c.front() == '(';
      }
    }
    out += " " + MergeCell(row) + " | " + LossToMergeCell(row) + " |\n";
  }
  if (partial)
    out += "\nRMSE in parentheses: over less than " + std::to_string(int(std::lround(100 * o.min_rate_for_rmse))) +
           " %" +
           " of the sequence's time (the rate beside it), not comparable with full rows.\n";
  for (const auto& row : rows) {
    for (size_t k = 0; k < row.runs.size(); ++k)
      for (const std::string& w : row.runs[k].warnings)
        out += "\nWARNING " + row.sequence + " run " + std::to_string(k + 1) + ": " + w;
  }
  if (out.back() != '\n') out += "\n";
  return out;
}

std::string FormatEvalTableCsv(const std::vector<TableRow>& rows, const EvalTableOptions& o) {
  std::string out = "sequence,runs";
  for (const char* m : {"po", "rumi", "front"}) {
    out += std::string(",") + m + "_rate," + m + "_rmse," + m + "_frames";
  }
  out += ",merges,loss_to_merge\n";
  for (const auto& row : rows) {
    out += row.sequence + "," + std::to_string(row.runs.size());
    for (const auto& m : Methods()) {
      for (const auto& c : Cells(row, m.second, o)) out += ",\"" + c + "\"";
    }
    out += ",\"" + MergeCell(row) + "\",\"" + LossToMergeCell(row) + "\"\n";
  }
  return out;
}

}  // namespace rumi
