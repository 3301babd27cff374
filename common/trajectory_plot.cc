#include "common/trajectory_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/atomic_file.h"

namespace rumi {

// Dark slate with unequal channels: anti-aliased black text on white (pure
// greys) never produces it, so tests can count ground-truth pixels exactly.
const cv::Scalar kPlotGroundTruthBgr(90, 60, 50);
const cv::Scalar kPlotNoSubmapBgr(175, 175, 175);

namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kText(0, 0, 0);
const cv::Scalar kFrameBgr(210, 210, 210);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

void Text(cv::Mat& img, const std::string& s, cv::Point org, double scale = 0.5,
          const cv::Scalar& colour = kText) {
  cv::putText(img, s, org, kFont, scale, colour, 1, cv::LINE_AA);
}

int TextWidth(const std::string& s, double scale = 0.5) {
  int baseline = 0;
  return cv::getTextSize(s, kFont, scale, 1, &baseline).width;
}

// 1, 2 or 5 times a power of ten, the largest not above x.
double NiceStep(double x) {
  if (!(x > 0) || !std::isfinite(x)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {5.0, 2.0, 1.0}) {
    if (m * p <= x) return m * p;
  }
  return p;
}

std::string FormatLength(double v) {
  char buf[32];
  if (v >= 1) {
    std::snprintf(buf, sizeof(buf), "%g", v);
  } else {
    std::snprintf(buf, sizeof(buf), "%.3g", v);
  }
  return buf;
}

// Maps plot coordinates (a, b) into a pixel box with equal scale on both axes.
struct Projection {
  double a0 = 0, b0 = 0, scale = 1;  // pixels per unit
  cv::Rect box;
  cv::Point operator()(double a, double b) const {
    return {box.x + static_cast<int>(std::lround((a - a0) * scale)),
            box.y + box.height - static_cast<int>(std::lround((b - b0) * scale))};
  }
};

Projection FitProjection(double amin, double amax, double bmin, double bmax, const cv::Rect& box) {
  Projection p;
  p.box = box;
  const double da = std::max(amax - amin, 1e-9), db = std::max(bmax - bmin, 1e-9);
  p.scale = std::min(box.width / da, box.height / db);
  // Centre the data in the box.
  p.a0 = 0.5 * (amin + amax) - 0.5 * box.width / p.scale;
  p.b0 = 0.5 * (bmin + bmax) - 0.5 * box.height / p.scale;
  return p;
}

struct AlignedSeries {
  std::vector<Eigen::Vector3d> points;
  std::vector<int64_t> ids;
  std::string note;  // about the alignment
};

AlignedSeries Align(const TopViewSeries& s, const Trajectory& gt, const TopViewOptions& o) {
  AlignedSeries out;
  Sim3 S;
  if (o.align_sim3 && !gt.empty() && !s.poses.empty()) {
    try {
      S = ComputeAte(s.poses, gt, o.ate).S_gt_est;
      out.note = "Sim(3)-aligned";
    } catch (const std::exception& e) {
      out.note = "not aligned";
    }
  } else if (!s.poses.empty()) {
    out.note = gt.empty() ? "no ground truth" : "not aligned";
  } else {
    out.note = "empty";
  }
  for (size_t i = 0; i < s.poses.size(); ++i) {
    out.points.push_back(S * s.poses[i].T_wc.translation());
    out.ids.push_back(i < s.submap_ids.size() ? s.submap_ids[i] : -1);
  }
  return out;
}

}  // namespace

cv::Scalar SubmapBgr(int64_t id) {
  // tab10 without its grey, in BGR.
  static const cv::Scalar kColours[] = {
      {180, 119, 31}, {14, 127, 255}, {44, 160, 44},  {40, 39, 214},  {189, 103, 148},
      {75, 86, 140},  {194, 119, 227}, {34, 189, 188}, {207, 190, 23}, {120, 30, 120}};
  if (id < 0) return kPlotNoSubmapBgr;
  return kColours[id % 10];
}

cv::Scalar TrackingStateBgr(TrackingState s) {
  switch (s) {
    case TrackingState::kTracking: return {80, 175, 76};       // green
    case TrackingState::kLost: return {54, 67, 244};           // red
    case TrackingState::kInitializing: return {7, 193, 255};   // amber
    case TrackingState::kCoarse: return {243, 150, 33};        // blue
  }
  return kPlotNoSubmapBgr;
}

cv::Scalar SampleSetBgr(int set) {
  switch (set) {
    // Darker than the submap palette so that ticks stay distinct from it.
    case 1: return {130, 60, 0};
    case 2: return {20, 20, 150};
    case 3: return {30, 100, 0};
  }
  return kPlotNoSubmapBgr;
}

bool TopViewOptions::Check(std::string* why) const {
  if (width < 200 || height < 200 || width > 20000 || height > 20000) {
    if (why) *why = "plot size must be within 200..20000 pixels";
    return false;
  }
  return ate.Check(why);
}

bool TimelineOptions::Check(std::string* why) const {
  if (width < 400 || height < 300 || width > 40000 || height > 20000) {
    if (why) *why = "timeline size must be at least 400 x 300 (and at most 40000 x 20000)";
    return false;
  }
  return true;
}

std::pair<int, int> PickPlotAxes(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return {0, 1};
  Eigen::Vector3d lo = points[0], hi = points[0];
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d ext = hi - lo;
  int smallest = 0;
  for (int k = 1; k < 3; ++k) {
    if (ext[k] < ext[smallest]) smallest = k;
  }
  const int a = smallest == 0 ? 1 : 0;
  const int b = smallest == 2 ? 1 : 2;
  return {a, b};
}

cv::Mat RenderTopView(const TopViewInput& input, const TopViewOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("TopViewOptions: " + why);
  cv::Mat img(o.height, o.width, CV_8UC3, kWhite);

  std::vector<AlignedSeries> series;
  for (const auto& s : input.series) series.push_back(Align(s, input.ground_truth, o));
  std::vector<Eigen::Vector3d> gt;
  for (const auto& p : input.ground_truth) gt.push_back(p.T_wc.translation());

  std::vector<Eigen::Vector3d> all = gt;
  if (all.empty()) {
    for (const auto& s : series) all.insert(all.end(), s.points.begin(), s.points.end());
  }
  const auto [ax, bx] = PickPlotAxes(all);
  for (const auto& s : series) all.insert(all.end(), s.points.begin(), s.points.end());

  const int top = 34;
  Text(img, input.title, {10, 22}, 0.6);
  const int panels = std::max<int>(1, static_cast<int>(series.size()));
  const int pw = o.width / panels;
  const char* kAxis = "xyz";

  double amin = 0, amax = 1, bmin = 0, bmax = 1;
  if (!all.empty()) {
    amin = amax = all[0][ax];
    bmin = bmax = all[0][bx];
    for (const auto& p : all) {
      amin = std::min(amin, p[ax]);
      amax = std::max(amax, p[ax]);
      bmin = std::min(bmin, p[bx]);
      bmax = std::max(bmax, p[bx]);
    }
  }
  for (int k = 0; k < panels; ++k) {
    const cv::Rect panel(k * pw, top, pw, o.height - top);
    const cv::Rect box(panel.x + 20, panel.y + 30, panel.width - 40, panel.height - 30 - 90);
    cv::rectangle(img, {box.x - 5, box.y - 5, box.width + 10, box.height + 10}, kFrameBgr, 1);
    const Projection proj = FitProjection(amin, amax, bmin, bmax, box);
    const AlignedSeries* s = k < static_cast<int>(series.size()) ? &series[k] : nullptr;
    std::string heading = s ? input.series[k].title + " (" + std::to_string(s->points.size()) +
                                  " poses, " + s->note + ")"
                            : std::string("ground truth");
    Text(img, heading, {panel.x + 20, panel.y + 20});
    if (all.empty()) {
      Text(img, "no poses", {box.x + box.width / 2 - 40, box.y + box.height / 2});
    }

    // Ground truth: plain 8-connected line so its grey stays exact.
    for (size_t i = 1; i < gt.size(); ++i) {
      cv::line(img, proj(gt[i - 1][ax], gt[i - 1][bx]), proj(gt[i][ax], gt[i][bx]),
               kPlotGroundTruthBgr, 2, cv::LINE_8);
    }
    if (gt.size() == 1) cv::circle(img, proj(gt[0][ax], gt[0][bx]), 3, kPlotGroundTruthBgr, -1);

    std::vector<int64_t> ids_seen;
    if (s) {
      for (size_t i = 0; i < s->points.size(); ++i) {
        const cv::Scalar c = SubmapBgr(s->ids[i]);
        const cv::Point p = proj(s->points[i][ax], s->points[i][bx]);
        if (i > 0 && s->ids[i] == s->ids[i - 1]) {
          cv::line(img, proj(s->points[i - 1][ax], s->points[i - 1][bx]), p, c, 1, cv::LINE_8);
        }
        cv::circle(img, p, 2, c, -1, cv::LINE_8);
        if (std::find(ids_seen.begin(), ids_seen.end(), s->ids[i]) == ids_seen.end()) {
          ids_seen.push_back(s->ids[i]);
        }
      }
    }

    // Scale bar: a round length near a quarter of the box width.
    const double len = NiceStep(0.25 * box.width / proj.scale);
    const int bar = static_cast<int>(std::lround(len * proj.scale));
    const int by = box.y + box.height + 25;
    cv::line(img, {box.x, by}, {box.x + bar, by}, kText, 2);
    cv::line(img, {box.x, by - 5}, {box.x, by + 5}, kText, 1);
    cv::line(img, {box.x + bar, by - 5}, {box.x + bar, by + 5}, kText, 1);
    Text(img, FormatLength(len) + (input.ground_truth.empty() ? " (map units)" : " m"),
         {box.x + bar + 8, by + 5});
    const std::string axes = std::string("right: ") + kAxis[ax] + ", up: " + kAxis[bx];
    Text(img, axes, {box.x + box.width - TextWidth(axes), by + 5});

    // Legend: ground truth, then the submaps (at most 8 named).
    int lx = box.x, ly = by + 35;
    auto swatch = [&](const cv::Scalar& c, const std::string& label) {
      const int w = 22 + TextWidth(label, 0.45) + 16;
      if (lx + w > box.x + box.width) {
        lx = box.x;
        ly += 20;
      }
      cv::rectangle(img, {lx, ly - 9, 16, 10}, c, -1, cv::LINE_8);
      Text(img, label, {lx + 22, ly}, 0.45);
      lx += w;
    };
    if (!gt.empty()) swatch(kPlotGroundTruthBgr, "ground truth");
    std::sort(ids_seen.begin(), ids_seen.end());
    for (size_t i = 0; i < ids_seen.size() && i < 8; ++i) {
      swatch(SubmapBgr(ids_seen[i]),
             ids_seen[i] < 0 ? std::string("no submap") : "submap " + std::to_string(ids_seen[i]));
    }
    if (ids_seen.size() > 8) Text(img, "+" + std::to_string(ids_seen.size() - 8) + " more", {lx, ly}, 0.45);
  }
  return img;
}

std::vector<TimelineSpan> WindowSpans(const std::vector<TimelineSample>& samples) {
  std::vector<TimelineSpan> spans;
  std::map<int64_t, size_t> index;
  for (const auto& s : samples) {
    auto it = index.find(s.window_id);
    if (it == index.end()) {
      index[s.window_id] = spans.size();
      spans.push_back({s.t, s.t, s.window_id});
    } else {
      TimelineSpan& w = spans[it->second];
      w.begin = std::min(w.begin, s.t);
      w.end = std::max(w.end, s.t);
    }
  }
  return spans;
}

cv::Mat RenderTimeline(const TimelineInput& in, const TimelineOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("TimelineOptions: " + why);
  cv::Mat img(o.height, o.width, CV_8UC3, kWhite);

  // Time range: as given, else everything that is drawn.
  Timestamp t0 = in.begin, t1 = in.end;
  if (t0 == 0 && t1 == 0) {
    bool any = false;
    auto take = [&](Timestamp t) {
      t0 = any ? std::min(t0, t) : t;
      t1 = any ? std::max(t1, t) : t;
      any = true;
    };
    for (const auto& f : in.frames) take(f.t);
    for (const auto& s : in.samples) take(s.t);
    for (const auto& w : in.windows) {
      take(w.begin);
      take(w.end);
    }
  }
  if (t1 <= t0) t1 = t0 + kNsPerSecond;
  const double span_s = NsToSeconds(t1 - t0);

  const int left = 120, right = o.width - 20;
  const int plot_w = right - left;
  auto X = [&](Timestamp t) {
    const double f = NsToSeconds(t - t0) / span_s;
    return left + static_cast<int>(std::lround(std::clamp(f, 0.0, 1.0) * plot_w));
  };
  auto visible = [&](Timestamp a, Timestamp b) { return b >= t0 && a <= t1; };

  Text(img, in.title.empty() ? std::string("timeline") : in.title, {10, 22}, 0.6);
  // State legend, top right.
  {
    int lx = right;
    const bool any_skipped =
        std::any_of(in.frames.begin(), in.frames.end(), [](const TimelineFrame& f) { return f.skipped; });
    auto entry = [&](const std::string& label, const cv::Scalar& colour) {
      lx -= 22 + TextWidth(label, 0.45) + 14;
      cv::rectangle(img, {lx, 12, 16, 10}, colour, -1);
      Text(img, label, {lx + 22, 22}, 0.45);
    };
    if (any_skipped) entry("skipped by replay", kPlotNoSubmapBgr);
    for (TrackingState s : {TrackingState::kCoarse, TrackingState::kInitializing,
                            TrackingState::kLost, TrackingState::kTracking})
      entry(ToString(s), TrackingStateBgr(s));
  }

  // Row geometry scales with the image height.
  const int axis_h = 45, top = 40;
  const int avail = o.height - top - axis_h;
  const int unit = avail / 8;  // state 2, submap 1.5, S1-S3 1 each, windows 1.5
  int y = top;
  const cv::Rect state_row(left, y, plot_w, 2 * unit - 4);
  y += 2 * unit;
  const cv::Rect submap_row(left, y, plot_w, unit + unit / 2 - 4);
  y += unit + unit / 2;
  cv::Rect set_rows[3];
  for (int k = 0; k < 3; ++k) {
    set_rows[k] = cv::Rect(left, y, plot_w, unit - 4);
    y += unit;
  }
  const cv::Rect window_row(left, y, plot_w, unit + unit / 2 - 4);
  auto label = [&](const cv::Rect& r, const std::string& s) {
    Text(img, s, {10, r.y + r.height / 2 + 5}, 0.45);
    cv::rectangle(img, r, kFrameBgr, 1);
  };
  label(state_row, "state");
  label(submap_row, "submap");
  for (int k = 0; k < 3; ++k) label(set_rows[k], "S" + std::to_string(k + 1));
  label(window_row, "back windows");

  if (in.frames.empty() && in.samples.empty() && in.windows.empty()) {
    Text(img, "no frames", {left + plot_w / 2 - 40, state_row.y + state_row.height / 2});
  }

  // Frame i fills [t_i, t_i+1); the last one a median interval.
  Timestamp median_dt = 0;
  if (in.frames.size() > 1) {
    std::vector<Timestamp> d;
    for (size_t i = 1; i < in.frames.size(); ++i) d.push_back(in.frames[i].t - in.frames[i - 1].t);
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    median_dt = std::max<Timestamp>(d[d.size() / 2], 0);
  }
  bool first_visible = true;
  for (size_t i = 0; i < in.frames.size(); ++i) {
    const TimelineFrame& f = in.frames[i];
    const Timestamp next = i + 1 < in.frames.size() ? in.frames[i + 1].t : f.t + median_dt;
    if (!visible(f.t, next)) continue;
    const bool label_submap = first_visible || in.frames[i - 1].submap_id != f.submap_id;
    first_visible = false;
    const int xa = X(f.t), xb = std::max(X(next), xa + 1);
    cv::rectangle(img, {xa, state_row.y + 1}, {xb - 1, state_row.y + state_row.height - 1},
                  f.skipped ? kPlotNoSubmapBgr : TrackingStateBgr(f.state), -1, cv::LINE_8);
    cv::rectangle(img, {xa, submap_row.y + 1}, {xb - 1, submap_row.y + submap_row.height - 1},
                  SubmapBgr(f.submap_id), -1, cv::LINE_8);
    if (label_submap) {
      cv::line(img, {xa, submap_row.y}, {xa, submap_row.y + submap_row.height}, kText, 1);
      if (f.submap_id >= 0) {
        Text(img, std::to_string(f.submap_id), {xa + 3, submap_row.y + submap_row.height - 6}, 0.45);
      }
    }
  }

  for (const auto& s : in.samples) {
    if (s.set < 1 || s.set > 3 || !visible(s.t, s.t)) continue;
    const cv::Rect& r = set_rows[s.set - 1];
    const int x = std::clamp(X(s.t), left + 1, right - 1);
    cv::line(img, {x, r.y + 2}, {x, r.y + r.height - 2}, SampleSetBgr(s.set), 2, cv::LINE_8);
  }

  for (size_t k = 0; k < in.windows.size(); ++k) {
    const TimelineSpan& w = in.windows[k];
    if (!visible(w.begin, w.end)) continue;
    // Two lanes so that neighbouring windows stay apart.
    const int lane_h = window_row.height / 2;
    const int ly = window_row.y + static_cast<int>(k % 2) * lane_h;
    const int xa = X(w.begin), xb = std::max(X(w.end), xa + 2);
    cv::rectangle(img, {xa, ly + 2}, {xb, ly + lane_h - 2}, SubmapBgr(w.id), -1, cv::LINE_8);
    Text(img, "w" + std::to_string(w.id), {xb + 3, ly + lane_h - 4}, 0.4);
  }

  // Time axis: seconds since t0 at round steps.
  const int ay = window_row.y + window_row.height + 8;
  cv::line(img, {left, ay}, {right, ay}, kText, 1);
  const double step = NiceStep(span_s / 8.0);
  for (double s = 0; s <= span_s + 1e-9; s += step) {
    const int x = left + static_cast<int>(std::lround(s / span_s * plot_w));
    cv::line(img, {x, ay}, {x, ay + 5}, kText, 1);
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%g", s);
    Text(img, buf, {x - TextWidth(buf, 0.4) / 2, ay + 20}, 0.4);
  }
  Text(img, "t - " + FormatSeconds(t0) + " [s]", {left, ay + 38}, 0.45);
  return img;
}

std::vector<int64_t> SubmapIdsByTime(const Trajectory& poses,
                                     const std::vector<TimelineFrame>& frames,
                                     Timestamp tolerance_ns) {
  std::vector<int64_t> ids(poses.size(), -1);
  if (frames.empty()) return ids;
  for (size_t i = 0; i < poses.size(); ++i) {
    const Timestamp t = poses[i].t;
    auto it = std::lower_bound(frames.begin(), frames.end(), t,
                               [](const TimelineFrame& f, Timestamp v) { return f.t < v; });
    Timestamp best = std::numeric_limits<Timestamp>::max();
    int64_t id = -1;
    for (auto c : {it, it == frames.begin() ? frames.end() : std::prev(it)}) {
      if (c == frames.end()) continue;
      const Timestamp d = c->t > t ? c->t - t : t - c->t;
      if (d < best) {
        best = d;
        id = c->submap_id;
      }
    }
    if (best <= tolerance_ns) ids[i] = id;
  }
  return ids;
}

void WritePng(const std::string& path, const cv::Mat& image) {
  std::vector<uint8_t> png;
  bool ok = false;
  try {
    ok = !image.empty() && cv::imencode(".png", image, png);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": cannot encode PNG: " + e.what());
  }
  if (!ok) throw std::runtime_error(path + ": cannot encode PNG");
  std::string why;
  if (!WriteFileAtomically(path, png.data(), png.size(), &why)) throw std::runtime_error(why);
}

}  // namespace rumi
