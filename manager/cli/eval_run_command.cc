// `rumi eval run PATH --dataset KIND`: runs rumi-manager, rumi-back and
// rumi-front on one sequence N times (process contract in docs/eval.md),
// then computes each run's metrics.json and plots, and prints the paper's
// Table IV for the output folder.
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "common/dataset.h"
#include "common/eval_table.h"
#include "common/logging.h"
#include "common/progress.h"
#include "common/run_metrics.h"
#include "common/trajectory.h"
#include "common/trajectory_plot.h"
#include "manager/cli/commands.h"

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
  double timeout_s = 0;  // 0: 600 s + 20 x the sequence duration / rate
  std::string bin_dir;   // default: the folder of this executable
};

volatile std::sig_atomic_t g_interrupted = 0;
void OnInterrupt(int) { g_interrupted = 1; }

std::string ExeDir() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot resolve /proc/self/exe: " + ec.message());
  return self.parent_path().string();
}

std::string Tail(const std::string& path, size_t max_bytes = 1200) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff from = size > static_cast<std::streamoff>(max_bytes)
                                  ? size - static_cast<std::streamoff>(max_bytes) : 0;
  in.seekg(from);
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return s;
}

// ---- the three processes ------------------------------------------------------
struct Child {
  std::string name;      // rumi-front, ...
  std::string log_path;  // its stdout + stderr
  std::string command;   // for messages
  pid_t pid = -1;
  bool running = false;
  int status = 0;        // waitpid status once exited
};

std::string Describe(int status) {
  if (WIFEXITED(status)) return "exited with code " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    return std::string("was killed by signal ") + std::to_string(WTERMSIG(status)) + " (" +
           strsignal(WTERMSIG(status)) + ")";
  }
  return "ended with status " + std::to_string(status);
}

std::string Quote(const std::vector<std::string>& argv) {
  std::string s;
  for (const auto& a : argv) s += (s.empty() ? "" : " ") + a;
  return s;
}

// Starts argv in process group *pgid (the first child founds it), output to
// log_path, stdin from /dev/null; dies with us (PR_SET_PDEATHSIG).
Child Spawn(const std::string& name, const std::vector<std::string>& argv,
            const std::string& log_path, pid_t* pgid) {
  Child c;
  c.name = name;
  c.log_path = log_path;
  c.command = Quote(argv);
  const int log_fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log_fd < 0) throw std::runtime_error("cannot create log " + log_path + ": " + strerror(errno));
  std::vector<char*> cargv;
  for (const auto& a : argv) cargv.push_back(const_cast<char*>(a.c_str()));
  cargv.push_back(nullptr);
  const pid_t group = *pgid;
  const pid_t pid = fork();
  if (pid < 0) {
    ::close(log_fd);
    throw std::runtime_error("fork failed for " + name + ": " + strerror(errno));
  }
  if (pid == 0) {
    setpgid(0, group > 0 ? group : 0);
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (null_fd >= 0) dup2(null_fd, STDIN_FILENO);
    dup2(log_fd, STDOUT_FILENO);
    dup2(log_fd, STDERR_FILENO);
    signal(SIGINT, SIG_DFL);
    execv(cargv[0], cargv.data());
    const std::string msg = "rumi eval run: cannot execute " + argv[0] + ": " + strerror(errno) + "\n";
    (void)!write(STDERR_FILENO, msg.data(), msg.size());
    _exit(127);
  }
  setpgid(pid, group > 0 ? group : pid);  // also here: no race with the child
  if (group <= 0) *pgid = pid;
  ::close(log_fd);
  c.pid = pid;
  c.running = true;
  return c;
}

void KillGroup(pid_t pgid, std::vector<Child>* children) {
  if (pgid <= 0) return;
  kill(-pgid, SIGTERM);
  // Give them 3 s to close their channels, then SIGKILL.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  auto any_running = [&] {
    bool any = false;
    for (Child& c : *children) {
      if (!c.running) continue;
      if (waitpid(c.pid, &c.status, WNOHANG) == c.pid) c.running = false; else any = true;
    }
    return any;
  };
  while (any_running() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (any_running()) {
    kill(-pgid, SIGKILL);
    for (Child& c : *children) {
      if (c.running && waitpid(c.pid, &c.status, 0) == c.pid) c.running = false;
    }
  }
}

// Segments of one instance (docs/ipc.md); a clean exit unlinks them, a killed
// producer leaves them behind.
void RemoveIpcSegments(const std::string& instance) {
  for (const char* channel : {"windows", "front_submaps", "back_submaps"}) {
    std::error_code ec;
    fs::remove(fs::path("/dev/shm") / ("rumi_" + instance + "_" + channel), ec);
  }
}

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

// Waits for all children; false (after killing the group) on the first
// failure, timeout or Ctrl-C, with the reason in *why.
bool WaitForChildren(std::vector<Child>* children, pid_t pgid, double timeout_s,
                     const std::string& frames_path, size_t num_frames, double expected_s,
                     ProgressLine* progress, std::string* why) {
  const auto start = std::chrono::steady_clock::now();
  LineCounter lines(frames_path);
  for (;;) {
    bool any_running = false;
    for (Child& c : *children) {
      if (!c.running) continue;
      const pid_t r = waitpid(c.pid, &c.status, WNOHANG);
      if (r == 0) {
        any_running = true;
        continue;
      }
      c.running = false;
      if (r < 0 || !WIFEXITED(c.status) || WEXITSTATUS(c.status) != 0) {
        KillGroup(pgid, children);
        std::string m = c.name + " " + Describe(c.status);
        m += "; command: " + c.command + "\nlog: " + c.log_path;
        const std::string tail = Tail(c.log_path);
        if (!tail.empty()) m += "\n--- last lines of " + c.log_path + " ---\n" + tail;
        // CLI11's parse errors exit with 100..114 (109: unexpected arguments).
        if (WIFEXITED(c.status) && WEXITSTATUS(c.status) >= 100 && WEXITSTATUS(c.status) <= 114) {
          m += "\n(" + c.name + " rejected its command line: does it implement the process contract "
               "of docs/eval.md yet?)";
        }
        *why = m;
        return false;
      }
    }
    if (!any_running) return true;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (g_interrupted) {
      KillGroup(pgid, children);
      *why = "interrupted";
      return false;
    }
    if (elapsed > timeout_s) {
      std::string running;
      for (const Child& c : *children) {
        if (c.running) running += "\n  " + c.name + " (log: " + c.log_path + ")";
      }
      KillGroup(pgid, children);
      *why = "timeout after " + FormatDuration(timeout_s) + "; still running:" + running;
      return false;
    }
    // Progress: the front's frames written so far; else time against the
    // expected replay duration (capped: the back may still be working).
    const size_t done = lines.Poll();
    bool front_running = false;
    for (const Child& c : *children) front_running |= c.running && c.name == "rumi-front";
    double fraction;
    std::string detail;
    if (!front_running) {
      fraction = 0.99;
      detail = "front done; waiting for";
      for (const Child& c : *children) {
        if (c.running) detail += " " + c.name;
      }
    } else if (done > 0) {
      fraction = std::min(0.98, static_cast<double>(done) / static_cast<double>(num_frames));
      detail = "frame " + std::to_string(done) + "/" + std::to_string(num_frames);
    } else {
      fraction = expected_s > 0 ? std::min(0.95, elapsed / expected_s) : 0.0;
      detail = "front running";
    }
    progress->Update(fraction, detail);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
}

// Converts the front's per-frame lines for the timeline and the timings.
void LoadFrontFrames(const fs::path& run_dir, std::vector<TimelineFrame>* timeline,
                     std::vector<double>* ms) {
  const fs::path p = run_dir / "front_frames.txt";
  if (!fs::exists(p)) {
    spdlog::warn("{} missing: no front timings, timeline without states", p.string());
    return;
  }
  const std::vector<FrontFrameLine> lines = ReadFrontFrames(p.string());
  bool all_ms = !lines.empty();
  for (const auto& l : lines) {
    timeline->push_back({l.t, l.state, l.submap_id, l.skipped});
    all_ms &= l.ms.has_value();
  }
  if (all_ms) {
    for (const auto& l : lines) ms->push_back(*l.ms);
  }
}

RunMetricsReport ComputeMetricsForRun(const EvalRunArgs& a, const Sequence& seq,
                                      const fs::path& run_dir, const std::string& sequence_name) {
  auto required = [&](const char* name) {
    const fs::path p = run_dir / name;
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
  in.front = ReadTumTrajectory(required("front.txt"), ro);
  std::vector<TimelineFrame> frames;
  LoadFrontFrames(run_dir, &frames, &in.front_ms);

  const fs::path front_stats = run_dir / "front_stats.json";
  if (fs::exists(front_stats)) {
    ReadFrontStats(front_stats.string(), &in.counts);
  } else {
    spdlog::warn("{} missing: front_saved_frames = 0", front_stats.string());
  }
  if (a.no_back) {
    in.merged = in.front;
    in.counts.saved_frames = in.counts.saved_frames_postculled = in.counts.front_saved_frames;
  } else {
    in.merged = ReadTumTrajectory(required("merged.txt"), ro);
    ReadBackStats(required("back/back_stats.json"), &in.counts);
    ReadManagerStats(required("manager_stats.json"), &in.counts);
  }
  const RunMetricsReport report = ComputeRunMetrics(in);
  WriteRunMetricsJson((run_dir / "metrics.json").string(), report);

  // Plots.
  std::vector<TimelineSample> samples;
  const fs::path samples_path = run_dir / "front_samples.txt";
  if (fs::exists(samples_path)) {
    for (const auto& s : ReadFrontSamples(samples_path.string())) {
      samples.push_back({s.t, s.set, s.window_id});
    }
  }
  TopViewInput top;
  top.title = sequence_name + "  " + run_dir.filename().string();
  top.ground_truth = seq.ground_truth;
  // A pose belongs to the front submap of its frame: match within half the
  // median frame interval.
  std::vector<Timestamp> dt;
  for (size_t i = 1; i < seq.frames.size(); ++i) dt.push_back(seq.frames[i] - seq.frames[i - 1]);
  std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
  const Timestamp tolerance = dt[dt.size() / 2] / 2;
  top.series.push_back(
      {"front (largest submap)", in.front, SubmapIdsByTime(in.front, frames, tolerance)});
  if (!a.no_back) {
    top.series.push_back(
        {"merged (largest map)", in.merged, SubmapIdsByTime(in.merged, frames, tolerance)});
  }
  WritePng((run_dir / "top_view.png").string(), RenderTopView(top));
  TimelineInput tl;
  tl.title = sequence_name + "  " + run_dir.filename().string() + ": front states, samples, back windows";
  tl.frames = std::move(frames);
  tl.samples = std::move(samples);
  tl.windows = WindowSpans(tl.samples);
  WritePng((run_dir / "timeline.png").string(), RenderTimeline(tl));
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
    tl.title = sequence_name + "  " + run_dir.filename().string() + ": first loss";
    WritePng((run_dir / "timeline_first_loss.png").string(), RenderTimeline(tl));
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
  const std::string bin_dir = a.bin_dir.empty() ? ExeDir() : a.bin_dir;
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

  g_interrupted = 0;
  auto old_int = std::signal(SIGINT, OnInterrupt);
  auto old_term = std::signal(SIGTERM, OnInterrupt);
  struct Restore {
    decltype(old_int) i, t;
    ~Restore() {
      std::signal(SIGINT, i);
      std::signal(SIGTERM, t);
    }
  } restore{old_int, old_term};

  TableRow row;
  row.sequence = sequence_name;
  for (int k = 1; k <= a.runs; ++k) {
    const fs::path run_dir = out / ("run_" + std::to_string(k));
    fs::create_directories(run_dir);
    for (const char* stale : {"metrics.json", "front.txt", "merged.txt", "front_frames.txt",
                              "front_samples.txt", "front_stats.json", "manager_stats.json",
                              "back/back_stats.json"}) {
      std::error_code ec;
      fs::remove(run_dir / stale, ec);  // a failed rerun must not pass on old results
    }
    if (!a.no_back) fs::create_directories(run_dir / "back");
    const std::string instance = "eval_" + std::to_string(getpid()) + "_" + std::to_string(k);
    RemoveIpcSegments(instance);

    auto with_config = [&](std::vector<std::string> v) {
      if (!a.config.empty()) {
        v.push_back("--config");
        v.push_back(a.config);
      }
      return v;
    };
    std::vector<Child> children;
    pid_t pgid = 0;
    std::string why;
    bool ok = true;
    try {
      if (!a.no_back) {
        children.push_back(Spawn("rumi-manager",
                                 with_config({manager_bin, "--instance", instance, "--out", run_dir.string()}),
                                 (run_dir / "rumi-manager.log").string(), &pgid));
        children.push_back(Spawn("rumi-back",
                                 with_config({back_bin, "--instance", instance, "--work", (run_dir / "back").string()}),
                                 (run_dir / "rumi-back.log").string(), &pgid));
      }
      std::vector<std::string> front_args = {front_bin, "--dataset", a.dataset, a.path, "--out",
                                             run_dir.string(), "--instance", instance, "--rate",
                                             rate > 0 ? a.rate : std::string("max")};
      // Front alone: no consumer will ever attach, so don't wait for one at the end.
      if (a.no_back) front_args.insert(front_args.end(), {"--wait-for-consumers", "0"});
      if (!a.odometry.empty()) front_args.insert(front_args.end(), {"--odometry", a.odometry});
      children.push_back(Spawn("rumi-front", with_config(front_args),
                               (run_dir / "rumi-front.log").string(), &pgid));
    } catch (const std::exception& e) {
      KillGroup(pgid, &children);
      RemoveIpcSegments(instance);
      throw;
    }
    ProgressLine progress(std::cerr, ProgressLine::IsTerminal(STDERR_FILENO),
                          "run " + std::to_string(k) + "/" + std::to_string(a.runs));
    ok = WaitForChildren(&children, pgid, timeout_s, (run_dir / "front_frames.txt").string(),
                         seq.frames.size(), replay_s, &progress, &why);
    RemoveIpcSegments(instance);
    if (!ok) {
      progress.Finish("failed");
      std::cerr << "rumi eval run: run " << k << " failed: " << why << "\n";
      return 1;
    }
    progress.Finish();
    const RunMetricsReport r = ComputeMetricsForRun(a, seq, run_dir, sequence_name);
    std::cout << "run " << k << ": front " << Percent(r.front.rate_time) << " rmse "
              << Rmse(r.front.ate_rmse) << ", merged " << Percent(r.merged.rate_time) << " rmse "
              << Rmse(r.merged.ate_rmse) << ", merges " << r.counts.merges << ", back windows "
              << r.counts.back_windows << " -> " << (run_dir / "metrics.json").string() << "\n";
    std::ifstream in(run_dir / "metrics.json");
    std::stringstream ss;
    ss << in.rdbuf();
    row.runs.push_back(ParseRunMetrics(ss.str(), (run_dir / "metrics.json").string()));
  }
  std::cout << "\n" << FormatEvalTableMarkdown({row});
  return 0;
}

}  // namespace

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
  cmd->add_option("--timeout", a->timeout_s,
                  "seconds per run before the processes are killed (default 600 + 20 x replay time)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--bin-dir", a->bin_dir,
                  "folder with rumi-front, rumi-back, rumi-manager (default: next to rumi)");
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
