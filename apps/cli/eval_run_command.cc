// `rumi eval run PATH --dataset KIND`: runs rumi-manager, rumi-back and
// rumi-front on one sequence N times (process contract in docs/eval.md),
// then computes each run's metrics.json and plots, and prints the paper's
// Table IV for the output folder.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "common/atomic_file.h"
#include "common/dataset.h"
#include "common/eval_table.h"
#include "common/logging.h"
#include "common/loss_to_merge.h"
#include "common/process/exit_codes.h"
#include "common/process/signals.h"
#include "common/process/subprocess.h"
#include "common/process/supervisor.h"
#include "common/progress.h"
#include "common/run_metrics.h"
#include "common/trajectory.h"
#include "common/trajectory_plot.h"
#include "apps/config/rumi_config.h"
#include "ipc/segments.h"
#include "apps/cli/commands.h"
#include "manager/map_file.h"
#include "manager/loop_audit.h"
#include "manager/merge_audit.h"

namespace rumi::cli {
namespace fs = std::filesystem;

namespace {

struct EvalRunArgs {
  std::string path;
  std::string dataset;
  std::string config;
  int runs = 1;
  std::string rate = "1.0";
  std::string out;
  std::string sequence;
  bool no_back = false;
  std::string odometry;  // optional pose source handed to rumi-front
  std::string imu;       // optional IMU file handed to rumi-front
  double timeout_s = 0;  // 0: 600 s + 20 x the sequence duration / rate
  std::string bin_dir;   // default: the folder of this executable
  bool overwrite = false;  // clear a run folder that holds an earlier run
};

// Counts lines of a growing file (front_frames.txt) without rereading it.
class LineCounter {
 public:
  explicit LineCounter(std::string path) : path_(std::move(path)) {}
  size_t Poll() {
    std::ifstream in(path_, std::ios::binary);
    if (!in) return lines_;
    in.seekg(offset_);
    char buf[65536];
    while (in.read(buf, sizeof(buf)) || in.gcount() > 0) {
      const std::streamsize n = in.gcount();
      for (std::streamsize i = 0; i < n; ++i) lines_ += buf[i] == '\n';
      offset_ += n;
      if (n < static_cast<std::streamsize>(sizeof(buf))) break;
    }
    return lines_;
  }

 private:
  std::string path_;
  std::streamoff offset_ = 0;
  size_t lines_ = 0;
};

// ---- one run --------------------------------------------------------------------
struct Sequence {
  std::vector<Timestamp> frames;
  Trajectory ground_truth;
  double duration_s = 0;
};

Sequence LoadSequence(const EvalRunArgs& a) {
  DatasetOptions o;
  if (!ParseDatasetKind(a.dataset, &o.kind)) {
    throw std::runtime_error("unknown dataset kind '" + a.dataset + "' (tum, euroc, icl, kitti, folder)");
  }
  o.path = a.path;
  o.config_path = a.config;
  std::string why;
  if (!o.Check(&why)) throw std::runtime_error("dataset options: " + why);
  const std::unique_ptr<FrameSource> source = OpenDataset(o);
  Sequence s;
  s.frames = source->timestamps();
  for (const auto& [t, T_wc] : source->ground_truth()) s.ground_truth.push_back({t, T_wc});
  if (s.frames.size() < 2) {
    throw std::runtime_error(a.path + ": the sequence lists " + std::to_string(s.frames.size()) +
                             " frames; at least 2 are needed");
  }
  s.duration_s = NsToSeconds(s.frames.back() - s.frames.front());
  return s;
}

std::string RequireBinary(const std::string& dir, const std::string& name) {
  const std::string p = (fs::path(dir) / name).string();
  if (access(p.c_str(), X_OK) != 0) {
    throw std::runtime_error(name + " not found or not executable at " + p +
                             " (build it: cmake --build <build> --target " + name +
                             "; or point --bin-dir at the folder holding it)");
  }
  return p;
}

// What the processes are doing, for the progress line: the front's frames
// written so far; once it ended, the back's window and stage (from its
// notify status) and the manager's state.
std::string Activity(const Supervisor& sup, int front, int back, int manager, size_t frames, size_t num_frames,
                     double* fraction) {
  if (sup.info(front).state == ChildState::kRunning) {
    *fraction = num_frames ? std::min(0.98, static_cast<double>(frames) / static_cast<double>(num_frames)) : 0.0;
    return frames ? "frame " + std::to_string(frames) + "/" + std::to_string(num_frames) : "front starting";
  }
  *fraction = std::nan("");  // what the back still has to do is not known: no ETA
  std::string d = "front done";
  if (back >= 0 && sup.info(back).state == ChildState::kRunning) {
    const nlohmann::json& st = sup.info(back).status;
    // Windows the queue joined into others or dropped are never built on
    // their own: what is left is the one being built and those waiting.
    const int built = st.value("built", 0) + st.value("failed", 0);
    const int waiting = st.value("queue", 0), joined = st.value("joined", 0), dropped = st.value("dropped", 0);
    const std::string queue_note = joined + dropped > 0 ? " (" + std::to_string(joined) + " joined, " +
                                                              std::to_string(dropped) + " dropped)"
                                                        : "";
    if (st.contains("building")) {
      const nlohmann::json& b = st["building"];
      char buf[160];
      std::snprintf(buf, sizeof(buf), "; back: window %d of %d (%d frames), %s, %.0f s", built + 1,
                    built + 1 + waiting, b.value("frames", 0), b.value("stage", std::string("?")).c_str(),
                    b.value("elapsed_s", 0.0));
      d += buf + queue_note;
    } else {
      d += "; back: " + std::to_string(built) + " windows built, " + std::to_string(waiting) + " waiting" + queue_note;
    }
  }
  if (manager >= 0 && sup.info(manager).state == ChildState::kRunning) {
    const nlohmann::json& st = sup.info(manager).status;
    d += "; manager: " + st.value("state", std::string("running"));
  }
  return d;
}

// Where one run's files are: `rumi eval run` keeps them in one run folder
// (the back's in back/); a rumid state folder has front/, back/ and the
// manager's files at its top.
struct RunFiles {
  fs::path front, back, manager;  // folders of front_*.txt/json, back_stats.json, merged.txt/manager_stats.json
  fs::path out;                   // metrics.json and the plots go here
  static RunFiles EvalRun(const fs::path& run_dir) { return {run_dir, run_dir / "back", run_dir, run_dir}; }
  static RunFiles DaemonState(const fs::path& state) { return {state / "front", state / "back", state, state}; }
};

// Converts the front's per-frame lines for the timeline and the timings.
std::vector<FrontFrameLine> LoadFrontFrames(const fs::path& front_dir, std::vector<TimelineFrame>* timeline,
                                            std::vector<double>* ms) {
  const fs::path p = front_dir / "front_frames.txt";
  if (!fs::exists(p)) {
    spdlog::warn("{} missing: no front timings, timeline without states", p.string());
    return {};
  }
  std::vector<FrontFrameLine> lines = ReadFrontFrames(p.string());
  bool all_ms = !lines.empty();
  for (const auto& l : lines) {
    timeline->push_back({l.t, l.state, l.submap_id, l.skipped});
    all_ms &= l.ms.has_value();
  }
  if (all_ms) {
    for (const auto& l : lines) ms->push_back(*l.ms);
  }
  return lines;
}

// Loss-to-merge times (common/loss_to_merge.h); left null with a log line
// when the front wrote no wall times.
void LossToMergeOfRun(const std::vector<FrontFrameLine>& lines, const RunFiles& files, RunMetricsReport* report) {
  if (lines.empty() || !lines.front().wall) {
    spdlog::warn("front_frames.txt has no wall_s column: no loss-to-merge times");
    return;
  }
  try {
    report->loss_to_merge = ComputeLossToMerge(
        lines, ReadBackSubmapTimes((files.back / "back_stats.json").string(),
                                   (files.manager / "manager_stats.json").string()));
  } catch (const std::exception& e) {
    spdlog::warn("no loss-to-merge times: {}", e.what());
  }
}

// The merge audit (manager/merge_audit.h) from the raw map and the manager's
// merge reports; skipped with a log line when either is missing.
void AuditRunMerges(const fs::path& manager_dir, const Trajectory& ground_truth, RunMetricsReport* report) {
  const fs::path raw = manager_dir / "map.rumi.raw", stats = manager_dir / "manager_stats.json";
  if (ground_truth.empty()) return;
  if (!fs::exists(raw)) {
    spdlog::warn("{} missing: no merge audit", raw.string());
    return;
  }
  GlobalMap map;
  std::string why;
  if (!LoadRawSubmaps(raw.string(), &map, &why)) {  // with what was baked since
    spdlog::warn("no merge audit: {}", why);
    return;
  }
  try {
    report->merge_audit = AuditMerges(map, ReadMergeAttempts(stats.string()), ground_truth);
  } catch (const std::exception& e) {
    spdlog::warn("no merge audit: {}", e.what());
    return;
  }
  report->merge_audit_done = true;
  try {
    report->loop_audit = AuditLoops(stats.string(), ground_truth);
    report->loop_audit_done = true;
    int loops_harmful = 0;
    for (const LoopAuditRow& l : report->loop_audit) loops_harmful += l.harmful;
    if (loops_harmful > 0)
      report->warnings.push_back(std::to_string(loops_harmful) +
                                 " closed loop(s) disagree with the ground truth (metrics.json loop_audit)");
  } catch (const std::exception& e) {
    spdlog::warn("no loop audit: {}", e.what());
  }
  int harmful = 0;
  for (const MergeAuditRow& m : report->merge_audit) harmful += m.accepted && m.harmful;
  if (harmful > 0)
    report->warnings.push_back(std::to_string(harmful) +
                               " accepted merge(s) made the map worse against the ground truth (metrics.json "
                               "merge_audit)");
}

RunMetricsReport ComputeMetricsForRun(bool no_back, const Sequence& seq, const RunFiles& files,
                                      const std::string& sequence_name, const std::string& title) {
  auto required = [&](const fs::path& p) {
    if (!fs::exists(p)) {
      throw std::runtime_error("the processes ended but " + p.string() +
                               " is missing (contract: docs/eval.md)");
    }
    return p.string();
  };
  TrajectoryReadOptions ro;
  ro.drop_duplicates = true;
  RunMetricsInput in;
  in.sequence = sequence_name;
  in.frames = seq.frames;
  in.ground_truth = seq.ground_truth;
  in.front = ReadTumTrajectory(required(files.front / "front.txt"), ro);
  std::vector<TimelineFrame> frames;
  const std::vector<FrontFrameLine> front_lines = LoadFrontFrames(files.front, &frames, &in.front_ms);

  const fs::path front_stats = files.front / "front_stats.json";
  if (fs::exists(front_stats)) {
    ReadFrontStats(front_stats.string(), &in.counts);
  } else {
    spdlog::warn("{} missing: front_saved_frames = 0", front_stats.string());
  }
  if (no_back) {
    in.merged = in.front;
    in.counts.saved_frames = in.counts.saved_frames_postculled = in.counts.front_saved_frames;
  } else {
    in.merged = ReadTumTrajectory(required(files.manager / "merged.txt"), ro);
    for (int k = 0; fs::exists(files.manager / ("merged_" + std::to_string(k) + ".txt")); ++k)
      in.components.push_back(
          ReadTumTrajectory((files.manager / ("merged_" + std::to_string(k) + ".txt")).string(), ro));
    ReadBackStats(required(files.back / "back_stats.json"), &in.counts);
    ReadManagerStats(required(files.manager / "manager_stats.json"), &in.counts);
  }
  RunMetricsReport report = ComputeRunMetrics(in);
  if (!no_back) {
    AuditRunMerges(files.manager, seq.ground_truth, &report);
    LossToMergeOfRun(front_lines, files, &report);
  }
  WriteRunMetricsJson((files.out / "metrics.json").string(), report);

  // Plots.
  std::vector<TimelineSample> samples;
  const fs::path samples_path = files.front / "front_samples.txt";
  if (fs::exists(samples_path)) {
    for (const auto& s : ReadFrontSamples(samples_path.string())) {
      samples.push_back({s.t, s.set, s.window_id});
    }
  }
  TopViewInput top;
  top.title = sequence_name + "  " + title;
  top.ground_truth = seq.ground_truth;
  // A pose belongs to the front submap of its frame: match within half the
  // median frame interval.
  std::vector<Timestamp> dt;
  for (size_t i = 1; i < seq.frames.size(); ++i) dt.push_back(seq.frames[i] - seq.frames[i - 1]);
  std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
  const Timestamp tolerance = dt[dt.size() / 2] / 2;
  top.series.push_back(
      {"front (largest submap)", in.front, SubmapIdsByTime(in.front, frames, tolerance)});
  if (!no_back) {
    top.series.push_back(
        {"merged (largest map)", in.merged, SubmapIdsByTime(in.merged, frames, tolerance)});
  }
  WritePng((files.out / "top_view.png").string(), RenderTopView(top));
  TimelineInput tl;
  tl.title = sequence_name + "  " + title + ": front states, samples, back windows";
  tl.frames = std::move(frames);
  tl.samples = std::move(samples);
  tl.windows = WindowSpans(tl.samples);
  WritePng((files.out / "timeline.png").string(), RenderTimeline(tl));
  // A Fig. 6-style close-up: 1 s before the first loss to 2 s after the
  // front tracks again.
  size_t i = 0;
  while (i < tl.frames.size() && tl.frames[i].state != TrackingState::kTracking) ++i;
  while (i < tl.frames.size() && tl.frames[i].state == TrackingState::kTracking) ++i;
  if (i < tl.frames.size()) {
    size_t j = i;
    while (j < tl.frames.size() && tl.frames[j].state != TrackingState::kTracking) ++j;
    const Timestamp resume = j < tl.frames.size() ? tl.frames[j].t : tl.frames.back().t;
    tl.begin = tl.frames[i].t - kNsPerSecond;
    tl.end = resume + 2 * kNsPerSecond;
    tl.title = sequence_name + "  " + title + ": first loss";
    WritePng((files.out / "timeline_first_loss.png").string(), RenderTimeline(tl));
  }
  return report;
}

std::string Percent(double x) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f %%", 100.0 * x);
  return buf;
}

std::string Rmse(const std::optional<double>& v) {
  if (!v) return "-";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4f", *v);
  return buf;
}

// The run folder must not hold an earlier run: the manager would reload its
// map and merge it in. --overwrite clears it.
void PrepareRunDir(const fs::path& run_dir, bool overwrite) {
  std::error_code ec;
  if (fs::exists(run_dir) && !fs::is_empty(run_dir, ec)) {
    if (!overwrite) {
      throw std::runtime_error(run_dir.string() +
                               " holds an earlier run (an evaluation starts from an empty map): pass --overwrite to "
                               "clear it, or give another --out");
    }
    fs::remove_all(run_dir, ec);
    if (ec) throw std::runtime_error("cannot clear " + run_dir.string() + ": " + ec.message());
    std::cout << "rumi eval run: cleared " << run_dir.string() << " (--overwrite)\n";
  }
  fs::create_directories(run_dir);
}

// Why a child's exit ends the run: its status, what it means, its command
// line, its log and the log's tail.
std::string ExitReport(const Supervisor& sup, int i) {
  const ChildInfo& in = sup.info(i);
  const ChildSpec& spec = sup.spec(i);
  std::string m = in.name + " " + DescribeWaitStatus(in.last_status);
  if (WIFEXITED(in.last_status)) m += std::string(" (") + DescribeExitCode(WEXITSTATUS(in.last_status)) + ")";
  std::string cmd;
  for (const std::string& arg : spec.argv) cmd += (cmd.empty() ? "" : " ") + arg;
  m += "; command: " + cmd + "\nlog: " + spec.log_path;
  const std::string tail = FileTail(spec.log_path, 1200);
  if (!tail.empty()) m += "\n--- last lines of " + spec.log_path + " ---\n" + tail;
  if (WIFEXITED(in.last_status) && WEXITSTATUS(in.last_status) >= 100 && WEXITSTATUS(in.last_status) <= 114) {
    m += "\n(" + in.name + " rejected its command line: does it implement the process contract of docs/eval.md yet?)";
  }
  return m;
}

int RunEval(const EvalRunArgs& a) {
  double rate = 0;  // 0: max
  if (a.rate != "max") {
    char* stop = nullptr;
    rate = std::strtod(a.rate.c_str(), &stop);
    if (stop != a.rate.c_str() + a.rate.size() || !(rate > 0) || !std::isfinite(rate)) {
      throw std::runtime_error("--rate must be a positive number or 'max', got '" + a.rate + "'");
    }
  }
  if (!a.config.empty() && !fs::is_regular_file(a.config)) {
    throw std::runtime_error("config file not found: " + a.config);
  }
  LoadRumiConfig(a.config);  // every section, before anything starts (throws ConfigError)
  const std::string bin_dir = a.bin_dir.empty() ? ExecutableDir() : a.bin_dir;
  const std::string front_bin = RequireBinary(bin_dir, "rumi-front");
  const std::string back_bin = a.no_back ? "" : RequireBinary(bin_dir, "rumi-back");
  const std::string manager_bin = a.no_back ? "" : RequireBinary(bin_dir, "rumi-manager");

  const Sequence seq = LoadSequence(a);
  const std::string sequence_name =
      a.sequence.empty() ? fs::absolute(a.path).lexically_normal().filename().string() : a.sequence;
  const double replay_s = rate > 0 ? seq.duration_s / rate : seq.duration_s * 0.5;
  const double timeout_s = a.timeout_s > 0 ? a.timeout_s : 600.0 + 20.0 * replay_s;
  const fs::path out = a.out.empty() ? fs::path("eval_" + sequence_name) : fs::path(a.out);
  fs::create_directories(out);
  std::cout << "rumi eval run: " << sequence_name << ", " << seq.frames.size() << " frames ("
            << FormatDuration(seq.duration_s) << "), ground truth "
            << (seq.ground_truth.empty() ? std::string("none") : std::to_string(seq.ground_truth.size()) + " poses")
            << ", " << a.runs << " run(s) into " << out.string() << ", timeout "
            << FormatDuration(timeout_s) << " per run" << (a.no_back ? ", front only" : "") << "\n";
  // Segments left by killed runs (their instance id holds a dead pid).
  for (const std::string& name : ReclaimStaleSegments())
    std::cout << "rumi eval run: removed the stale shared-memory segment " << name << "\n";
  ProcessSignals::Install();  // Ctrl-C: stop the children; a second one ends us at once

  TableRow row;
  row.sequence = sequence_name;
  for (int k = 1; k <= a.runs; ++k) {
    const fs::path run_dir = out / ("run_" + std::to_string(k));
    PrepareRunDir(run_dir, a.overwrite);
    if (!a.no_back) fs::create_directories(run_dir / "back");
    const std::string instance = "eval_" + std::to_string(getpid()) + "_" + std::to_string(k);
    auto with_config = [&](std::vector<std::string> v) {
      if (!a.config.empty()) v.insert(v.end(), {"--config", a.config});
      return v;
    };
    SupervisorOptions so;
    so.restart = false;  // an evaluation gets one run: the first failure ends it
    so.notify_name = "rumi-eval-" + std::to_string(getpid()) + "-" + std::to_string(k);
    Supervisor sup(so);
    auto add = [&](const char* name, std::vector<std::string> argv, bool low_priority) {
      ChildSpec c;
      c.name = name;
      c.argv = std::move(argv);
      c.log_path = (run_dir / (std::string(name) + ".log")).string();
      c.truncate_log = true;
      c.low_priority = low_priority;
      return sup.Add(std::move(c));
    };
    int manager = -1, back = -1;
    if (!a.no_back) {
      manager = add("rumi-manager", with_config({manager_bin, "--instance", instance, "--out", run_dir.string()}),
                    false);
      back = add("rumi-back", with_config({back_bin, "--instance", instance, "--work", (run_dir / "back").string()}),
                 false);  // it lowers its own priority (back.low_priority)
    }
    std::vector<std::string> front_args = {front_bin, "--dataset", a.dataset, a.path, "--out",
                                           run_dir.string(), "--instance", instance, "--rate",
                                           rate > 0 ? a.rate : std::string("max")};
    // Front alone: no consumer will ever attach, so don't wait for one at the end.
    if (a.no_back) front_args.insert(front_args.end(), {"--wait-for-consumers", "0"});
    if (!a.odometry.empty()) front_args.insert(front_args.end(), {"--odometry", a.odometry});
    if (!a.imu.empty()) front_args.insert(front_args.end(), {"--imu", a.imu});
    const int front = add("rumi-front", with_config(front_args), false);
    std::string why;
    for (int i = 0; i < static_cast<int>(sup.size()); ++i) {
      if (!sup.Start(i, &why)) {
        sup.KillAll();
        RemoveInstanceSegments(instance, true);
        throw std::runtime_error(sup.info(i).name + ": " + why);
      }
    }
    ProgressLine progress(std::cerr, ProgressLine::IsTerminal(STDERR_FILENO),
                          "run " + std::to_string(k) + "/" + std::to_string(a.runs));
    LineCounter lines((run_dir / "front_frames.txt").string());
    const auto start = std::chrono::steady_clock::now();
    std::string failure;
    while (sup.AnyRunning() && failure.empty()) {
      for (const Supervisor::Exit& e : sup.Poll(0.2)) {
        if (!(WIFEXITED(e.status) && WEXITSTATUS(e.status) == kExitDone)) failure = ExitReport(sup, e.child);
      }
      if (!failure.empty()) break;
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (ProcessSignals::stop()->load()) {
        failure = "interrupted";
      } else if (elapsed > timeout_s) {
        failure = "timeout after " + FormatDuration(timeout_s) + "; still running:";
        for (size_t i = 0; i < sup.size(); ++i)
          if (sup.info(int(i)).state == ChildState::kRunning)
            failure += "\n  " + sup.info(int(i)).name + " (log: " + sup.spec(int(i)).log_path + ")";
      }
      double fraction = 0;
      const std::string detail = Activity(sup, front, back, manager, lines.Poll(), seq.frames.size(), &fraction);
      progress.Update(fraction, detail);
    }
    if (!failure.empty()) sup.StopAll({front, back, manager}, 3.0);
    RemoveInstanceSegments(instance, true);
    if (!failure.empty()) {
      progress.Finish("failed");
      std::cerr << "rumi eval run: run " << k << " failed: " << failure << "\n";
      return 1;
    }
    progress.Finish();
    const RunMetricsReport r =
        ComputeMetricsForRun(a.no_back, seq, RunFiles::EvalRun(run_dir), sequence_name, run_dir.filename().string());
    std::cout << "run " << k << ": front " << Percent(r.front.rate_time) << " rmse "
              << Rmse(r.front.ate_rmse) << ", merged " << Percent(r.merged.rate_time) << " rmse "
              << Rmse(r.merged.ate_rmse) << ", merges " << r.counts.merges << ", back windows "
              << r.counts.back_windows << " -> " << (run_dir / "metrics.json").string() << "\n";
    for (const std::string& w : r.warnings) std::cout << "WARNING run " << k << ": " << w << "\n";
    std::string text, problem;
    if (!ReadFileText((run_dir / "metrics.json").string(), &text, &problem)) throw std::runtime_error(problem);
    row.runs.push_back(ParseRunMetrics(text, (run_dir / "metrics.json").string()));
  }
  std::cout << "\n" << FormatEvalTableMarkdown({row});
  return 0;
}

// `rumi eval session`: the same metrics for what a rumid session left in its
// state folder, against the dataset it replayed.
int RunSessionEval(const EvalRunArgs& a, const fs::path& state) {
  if (!fs::exists(state / "merged.txt")) {
    throw std::runtime_error(state.string() + " holds no merged.txt: is it the state folder of a rumid session?");
  }
  const Sequence seq = LoadSequence(a);
  const std::string name =
      a.sequence.empty() ? fs::absolute(a.path).lexically_normal().filename().string() : a.sequence;
  const RunMetricsReport r = ComputeMetricsForRun(false, seq, RunFiles::DaemonState(state), name, "rumid session");
  std::cout << "rumid session " << state.string() << ": front " << Percent(r.front.rate_time) << " rmse "
            << Rmse(r.front.ate_rmse) << ", merged " << Percent(r.merged.rate_time) << " rmse "
            << Rmse(r.merged.ate_rmse) << ", merges " << r.counts.merges << ", back windows " << r.counts.back_windows
            << " -> " << (state / "metrics.json").string() << "\n";
  for (const std::string& w : r.warnings) std::cout << "WARNING: " << w << "\n";
  TableRow row;
  row.sequence = name;
  row.runs.push_back(ParseRunMetrics(FormatRunMetricsJson(r), (state / "metrics.json").string()));
  std::cout << "\n" << FormatEvalTableMarkdown({row});
  return 0;
}

}  // namespace

void AddEvalSessionCommand(CLI::App* eval) {
  auto a = std::make_shared<EvalRunArgs>();
  auto state = std::make_shared<std::string>();
  CLI::App* cmd = eval->add_subcommand(
      "session", "metrics.json, plots and the table for a rumid session (its state folder) on a replayed dataset");
  cmd->add_option("state", *state, "the session's state folder (--state-dir, daemon.state_dir)")->required();
  cmd->add_option("path", a->path, "the dataset the session replayed")->required();
  cmd->add_option("--dataset", a->dataset, "dataset kind: tum, euroc, icl, kitti, folder")
      ->required()
      ->check(CLI::IsMember({"tum", "euroc", "icl", "kitti", "folder"}));
  cmd->add_option("--config", a->config, "config with the dataset's camera: section (rumi synth: camera.yaml)");
  cmd->add_option("--sequence", a->sequence, "sequence name in metrics.json (default: folder name)");
  cmd->callback([a, state] {
    try {
      RunSessionEval(*a, *state);
    } catch (const std::exception& e) {
      std::cerr << "rumi eval session: " << e.what() << "\n";
      throw CLI::RuntimeError(1);
    }
  });
}

void AddEvalRunCommand(CLI::App* eval) {
  auto a = std::make_shared<EvalRunArgs>();
  CLI::App* cmd = eval->add_subcommand(
      "run", "run rumi-manager, rumi-back and rumi-front on a sequence; write metrics.json and plots");
  cmd->add_option("path", a->path, "dataset folder")->required();
  cmd->add_option("--dataset", a->dataset, "dataset kind: tum, euroc, icl, kitti, folder")
      ->required()
      ->check(CLI::IsMember({"tum", "euroc", "icl", "kitti", "folder"}));
  cmd->add_option("--config", a->config, "rumi YAML config handed to the three processes");
  cmd->add_option("--runs", a->runs, "number of runs (run_1 ... run_N)")->check(CLI::Range(1, 1000));
  cmd->add_option("--rate", a->rate, "replay speed: 1.0 = recorded rate (default), or 'max'");
  cmd->add_option("--out", a->out, "output folder (default eval_<sequence>)");
  cmd->add_option("--sequence", a->sequence, "sequence name in metrics.json (default: folder name)");
  cmd->add_flag("--no-back", a->no_back, "run the front alone (merged = front)");
  cmd->add_option("--odometry", a->odometry,
                  "TUM file of a pose source (robot odometry; `rumi synth` writes odometry.txt) for the "
                  "front: the manager then also joins submaps by it; default: vision only")
      ->check(CLI::ExistingFile);
  cmd->add_option("--imu", a->imu,
                  "IMU file (EuRoC imu0 columns; `rumi synth` writes imu.csv): the front's gyro prior")
      ->check(CLI::ExistingFile);
  cmd->add_option("--timeout", a->timeout_s,
                  "seconds per run before the processes are killed (default 600 + 20 x replay time)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--bin-dir", a->bin_dir,
                  "folder with rumi-front, rumi-back, rumi-manager (default: next to rumi)");
  cmd->add_flag("--overwrite", a->overwrite,
                "clear run folders that hold an earlier run (by default such a folder is refused)");
  cmd->callback([a] {
    int rc = 1;
    try {
      rc = RunEval(*a);
    } catch (const std::exception& e) {
      std::cerr << "rumi eval run: " << e.what() << "\n";
      throw CLI::RuntimeError(1);
    }
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace rumi::cli
