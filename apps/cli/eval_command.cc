// `rumi eval ate EST GT`: absolute trajectory error of an estimate against
// ground truth (association, Umeyama alignment, error statistics), as evo_ape.
// Other `eval` subcommands (table, run) register themselves under `eval`.
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "common/trajectory.h"
#include "common/trajectory_eval.h"
#include "apps/cli/commands.h"

namespace rumi::cli {
namespace {

struct AteArgs {
  std::string est_path, gt_path;
  std::string format = "auto";     // both files unless gt_format is given
  std::string gt_format;           // empty: same as --format
  std::string est_times, gt_times;  // KITTI times files
  std::string align = "sim3";
  double max_diff_s = 0.02;
  bool by_index = false;
  bool strict = false;  // one-to-one pairs, duplicate timestamps refused
  std::string frames_path;  // sequence frame timestamps, for tracking rates
  std::string errors_path;  // per-pair errors out
  bool json = false;
};

Trajectory Load(const std::string& path, const std::string& format_name,
                const std::string& times, bool drop_duplicates, TrajectoryFormat* format) {
  if (format_name == "auto") {
    *format = DetectTrajectoryFormat(path);
  } else if (!ParseTrajectoryFormat(format_name, format)) {
    throw std::runtime_error("unknown format '" + format_name + "'");
  }
  if (!times.empty() && *format != TrajectoryFormat::kKitti) {
    throw std::runtime_error("a times file only applies to KITTI trajectories ('" + path +
                             "' is " + ToString(*format) + ")");
  }
  TrajectoryReadOptions ro;
  ro.drop_duplicates = drop_duplicates;
  Trajectory traj = ReadTrajectory(path, *format, times, ro);
  if (traj.empty()) throw std::runtime_error("'" + path + "' holds no poses");
  return traj;
}

nlohmann::json StatsJson(const ErrorStats& s) {
  return {{"count", s.count}, {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"std", s.std},     {"min", s.min},   {"max", s.max},   {"sse", s.sse}};
}

void WriteErrors(const std::string& path, const Trajectory& est, const Trajectory& gt,
                 const AteResult& r) {
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw std::runtime_error("cannot open '" + path + "' for writing");
  std::fprintf(f, "# t_est t_gt translation_error\n");
  for (size_t k = 0; k < r.pairs.size(); ++k) {
    std::fprintf(f, "%s %s %.9f\n", FormatSeconds(est[r.pairs[k].est].t).c_str(),
                 FormatSeconds(gt[r.pairs[k].gt].t).c_str(), r.translation_errors[k]);
  }
  if (std::fclose(f) != 0) throw std::runtime_error("write to '" + path + "' failed");
}

int RunAte(const AteArgs& a) {
  AteOptions o;
  if (!ParseAlignment(a.align, &o.alignment)) {
    throw std::runtime_error("unknown alignment '" + a.align + "' (none, se3, sim3)");
  }
  o.association.max_diff_s = a.max_diff_s;
  // evo's rules unless --strict: a pose of the longer trajectory may pair
  // twice, and of poses with equal timestamps the first is used.
  o.association.one_to_one = a.strict;
  const bool drop_duplicates = !a.strict;
  o.match_by_index = a.by_index;
  std::string why;
  if (!o.Check(&why)) throw std::runtime_error(why);

  TrajectoryFormat est_format, gt_format;
  const Trajectory est = Load(a.est_path, a.format, a.est_times, drop_duplicates, &est_format);
  const Trajectory gt = Load(a.gt_path, a.gt_format.empty() ? a.format : a.gt_format, a.gt_times,
                             drop_duplicates, &gt_format);
  const AteResult r = ComputeAte(est, gt, o);
  if (!a.errors_path.empty()) WriteErrors(a.errors_path, est, gt, r);

  bool have_rate = false;
  TrackingRate rate;
  if (!a.frames_path.empty()) {
    rate = ComputeTrackingRate(ReadTimestampList(a.frames_path), est);
    have_rate = true;
  }

  const Sim3& S = r.S_gt_est;
  if (a.json) {
    nlohmann::json j;
    j["estimate"] = {{"path", a.est_path}, {"format", ToString(est_format)}, {"poses", est.size()}};
    j["ground_truth"] = {{"path", a.gt_path}, {"format", ToString(gt_format)}, {"poses", gt.size()}};
    j["association"] = {{"by_index", o.match_by_index},
                        {"max_diff_s", o.association.max_diff_s},
                        {"one_to_one", o.association.one_to_one},
                        {"pairs", r.pairs.size()},
                        {"max_abs_dt_s", r.max_abs_dt_s}};
    const Eigen::Quaterniond& q = S.rotation();
    j["alignment"] = {{"kind", ToString(r.alignment)},
                      {"along_line", r.line_alignment},
                      {"scale", S.scale()},
                      {"rotation_wxyz", {q.w(), q.x(), q.y(), q.z()}},
                      {"translation", {S.translation().x(), S.translation().y(), S.translation().z()}}};
    j["ate_translation"] = StatsJson(r.translation);
    j["ate_rotation_deg"] = StatsJson(r.rotation_deg);
    if (have_rate) {
      j["tracking"] = {{"frames", rate.num_frames},
                       {"tracked_frames", rate.num_tracked_frames},
                       {"frame_rate", rate.frame_rate},
                       {"sequence_duration_s", rate.sequence_duration_s},
                       {"covered_duration_s", rate.covered_duration_s},
                       {"covered_rate", rate.covered_rate},
                       {"tracked_duration_s", rate.tracked_duration_s},
                       {"tracked_rate", rate.tracked_rate},
                       {"segments", rate.num_segments}};
    }
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::printf("estimate:     %s (%s, %zu poses)\n", a.est_path.c_str(), ToString(est_format),
              est.size());
  std::printf("ground truth: %s (%s, %zu poses)\n", a.gt_path.c_str(), ToString(gt_format),
              gt.size());
  if (o.match_by_index) {
    std::printf("association:  %zu pairs by index\n", r.pairs.size());
  } else {
    std::printf("association:  %zu pairs (max_diff %.4g s, largest |dt| %.4g s%s)\n",
                r.pairs.size(), o.association.max_diff_s, r.max_abs_dt_s,
                o.association.one_to_one ? ", one-to-one (--strict)" : "");
  }
  const Eigen::AngleAxisd aa(S.rotation());
  std::printf("alignment:    %s%s, scale %.9g, rotation %.6g deg, translation [%.6g %.6g %.6g]\n",
              ToString(r.alignment),
              r.line_alignment ? " along the line (ground truth is straight; angle about it from the orientations)"
                               : "",
              S.scale(), aa.angle() * 180.0 / M_PI, S.translation().x(), S.translation().y(),
              S.translation().z());
  const ErrorStats& t = r.translation;
  std::printf("ATE (translation): rmse %.9g  mean %.9g  median %.9g  std %.9g  min %.9g  max %.9g"
              "  (%zu pairs)\n",
              t.rmse, t.mean, t.median, t.std, t.min, t.max, t.count);
  const ErrorStats& rd = r.rotation_deg;
  std::printf("rotation (deg):    rmse %.6g  mean %.6g  median %.6g  max %.6g\n", rd.rmse, rd.mean,
              rd.median, rd.max);
  if (have_rate) {
    std::printf("tracking:     covered %.4f (%.3f of %.3f s), in segments %.4f (%zu segments), "
                "frames %.4f (%zu of %zu)\n",
                rate.covered_rate, rate.covered_duration_s, rate.sequence_duration_s,
                rate.tracked_rate, rate.num_segments, rate.frame_rate, rate.num_tracked_frames,
                rate.num_frames);
  }
  return 0;
}

void AddAteCommand(CLI::App* eval) {
  auto a = std::make_shared<AteArgs>();
  CLI::App* cmd = eval->add_subcommand(
      "ate", "absolute trajectory error of an estimate against ground truth (as evo_ape)");
  cmd->add_option("estimate", a->est_path, "estimated trajectory")->required();
  cmd->add_option("ground_truth", a->gt_path, "ground-truth trajectory")->required();
  cmd->add_option("--align", a->align, "alignment before measuring: sim3 (default), se3, none")
      ->check(CLI::IsMember({"sim3", "se3", "none"}));
  cmd->add_option("--max-diff", a->max_diff_s, "association tolerance in seconds (default 0.02)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--format", a->format,
                  "file format of both trajectories: auto (default), tum, kitti, euroc")
      ->check(CLI::IsMember({"auto", "tum", "kitti", "euroc"}));
  cmd->add_option("--gt-format", a->gt_format, "ground-truth format when it differs from --format")
      ->check(CLI::IsMember({"auto", "tum", "kitti", "euroc"}));
  cmd->add_option("--est-times", a->est_times, "KITTI times file for the estimate");
  cmd->add_option("--gt-times", a->gt_times, "KITTI times file for the ground truth");
  cmd->add_flag("--by-index", a->by_index, "pair the i-th poses, ignoring timestamps (KITTI)");
  cmd->add_flag("--strict", a->strict,
                "a pose pairs at most once and equal timestamps are an error (default: evo's rules, "
                "a ground-truth pose may pair twice and the first of equal timestamps is used)");
  cmd->add_option("--frames", a->frames_path,
                  "sequence frame timestamps (first column, seconds) to report tracking rates");
  cmd->add_option("--errors", a->errors_path, "write per-pair translation errors to this file");
  cmd->add_flag("--json", a->json, "print the result as JSON");
  cmd->callback([a] {
    int rc = 1;
    try {
      rc = RunAte(*a);
    } catch (const std::exception& e) {
      std::cerr << "rumi eval ate: " << e.what() << "\n";
      throw CLI::RuntimeError(1);
    }
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace

void RegisterEvalCommands(CLI::App* app) {
  CLI::App* eval = app->add_subcommand("eval", "evaluate trajectories");
  eval->require_subcommand(1);
  AddAteCommand(eval);
}

}  // namespace rumi::cli
