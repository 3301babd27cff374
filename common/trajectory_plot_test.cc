#include "common/trajectory_plot.h"

#include <gtest/gtest.h>

#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

constexpr Timestamp kT0 = 1000 * kNsPerSecond;
constexpr Timestamp kDt = 50000000;  // 20 Hz

struct ColourBox {
  int count = 0;
  cv::Rect box;
};

// Pixels of exactly colour c in rows [y0, y1).
ColourBox FindColour(const cv::Mat& img, const cv::Scalar& c, int y0, int y1) {
  ColourBox r;
  int xmin = img.cols, xmax = -1, ymin = img.rows, ymax = -1;
  const cv::Vec3b v(static_cast<uchar>(c[0]), static_cast<uchar>(c[1]), static_cast<uchar>(c[2]));
  for (int y = std::max(0, y0); y < std::min(img.rows, y1); ++y) {
    for (int x = 0; x < img.cols; ++x) {
      if (img.at<cv::Vec3b>(y, x) != v) continue;
      ++r.count;
      xmin = std::min(xmin, x);
      xmax = std::max(xmax, x);
      ymin = std::min(ymin, y);
      ymax = std::max(ymax, y);
    }
  }
  if (r.count) r.box = cv::Rect(xmin, ymin, xmax - xmin + 1, ymax - ymin + 1);
  return r;
}

// Camera-style ground truth: a 4 m x 2 m rectangle in the x-z plane, y ~ 0.
Trajectory RectangleGt() {
  Trajectory gt;
  int i = 0;
  auto add = [&](double x, double z) {
    gt.push_back({kT0 + i * kDt, Se3(Eigen::Quaterniond::Identity(),
                                     Eigen::Vector3d(x, 0.01 * std::sin(i), z))});
    ++i;
  };
  for (int k = 0; k < 40; ++k) add(0.1 * k, 0);
  for (int k = 0; k < 20; ++k) add(4, 0.1 * k);
  for (int k = 0; k < 40; ++k) add(4 - 0.1 * k, 2);
  for (int k = 0; k < 20; ++k) add(0, 2 - 0.1 * k);
  return gt;
}

TopViewInput Scene() {
  TopViewInput in;
  in.title = "test";
  in.ground_truth = RectangleGt();
  // Estimate: the same path at scale 0.3, rotated and shifted.
  const Sim3 S(0.3, Eigen::Quaterniond(Eigen::AngleAxisd(1.0, Eigen::Vector3d(0, 1, 1).normalized())),
               Eigen::Vector3d(5, 5, 5));
  TopViewSeries s;
  s.title = "merged";
  for (size_t i = 0; i < in.ground_truth.size(); ++i) {
    s.poses.push_back({in.ground_truth[i].t, S.TransformPose(in.ground_truth[i].T_wc)});
    s.submap_ids.push_back(i < 60 ? 0 : 1);
  }
  in.series.push_back(s);
  return in;
}

TEST(TrajectoryPlot, PicksAxesOfLargestExtent) {
  std::vector<Eigen::Vector3d> xz = {{0, 0, 0}, {4, 0.1, 0}, {4, -0.1, 2}};
  EXPECT_EQ(PickPlotAxes(xz), std::make_pair(0, 2));
  std::vector<Eigen::Vector3d> yz = {{0, 0, 0}, {0.1, 3, 0}, {0, 3, -2}};
  EXPECT_EQ(PickPlotAxes(yz), std::make_pair(1, 2));
  std::vector<Eigen::Vector3d> xy = {{0, 0, 0}, {1, 2, 0.5}};
  EXPECT_EQ(PickPlotAxes(xy), std::make_pair(0, 1));
}

TEST(TrajectoryPlot, TopViewAlignsEstimateOntoGroundTruth) {
  TopViewOptions o;
  o.width = 800;
  o.height = 600;
  const cv::Mat img = RenderTopView(Scene(), o);
  ASSERT_EQ(img.cols, 800);
  ASSERT_EQ(img.rows, 600);
  ASSERT_EQ(img.type(), CV_8UC3);
  const int plot_end = 600 - 100;  // above scale bar and legend
  const ColourBox gt = FindColour(img, kPlotGroundTruthBgr, 0, plot_end);
  const ColourBox s0 = FindColour(img, SubmapBgr(0), 0, plot_end);
  const ColourBox s1 = FindColour(img, SubmapBgr(1), 0, plot_end);
  EXPECT_GT(gt.count, 500);
  EXPECT_GT(s0.count, 100);
  EXPECT_GT(s1.count, 100);
  // Rectangle 4 x 2: drawn wider than tall (x right, z up).
  EXPECT_GT(gt.box.width, 1.8 * gt.box.height);
  // After Sim(3) alignment both submaps together cover the ground truth box.
  const cv::Rect est = s0.box | s1.box;
  EXPECT_NEAR(est.x, gt.box.x, 4);
  EXPECT_NEAR(est.y, gt.box.y, 4);
  EXPECT_NEAR(est.width, gt.box.width, 6);
  EXPECT_NEAR(est.height, gt.box.height, 6);
  // Submap 0 is the first 60 poses: the bottom edge and the right side.
  EXPECT_GT(s0.box.y + s0.box.height, s1.box.y + s1.box.height - 5);
  EXPECT_LT(s1.box.x, s0.box.x + 5);

  // Without alignment the estimate lies elsewhere.
  o.align_sim3 = false;
  const cv::Mat raw = RenderTopView(Scene(), o);
  const cv::Rect est_raw = FindColour(raw, SubmapBgr(0), 0, plot_end).box |
                           FindColour(raw, SubmapBgr(1), 0, plot_end).box;
  const cv::Rect gt_raw = FindColour(raw, kPlotGroundTruthBgr, 0, plot_end).box;
  EXPECT_GT(std::abs(est_raw.width - gt_raw.width) + std::abs(est_raw.x - gt_raw.x), 20);
}

TEST(TrajectoryPlot, GroundTruthColourOnlyWithGroundTruth) {
  TopViewInput in = Scene();
  in.ground_truth.clear();
  const cv::Mat img = RenderTopView(in);
  EXPECT_EQ(FindColour(img, kPlotGroundTruthBgr, 0, img.rows).count, 0);
  EXPECT_GT(FindColour(img, SubmapBgr(0), 0, img.rows).count, 100);
}

TEST(TrajectoryPlot, WritesPngOfTheRightSize) {
  const TempDir tmp;
  const std::filesystem::path dir = tmp.Create();
  TopViewOptions o;
  o.width = 640;
  o.height = 480;
  const std::string top = (dir / "top.png").string();
  WritePng(top, RenderTopView(Scene(), o));
  const cv::Mat back = cv::imread(top, cv::IMREAD_COLOR);
  ASSERT_FALSE(back.empty());
  EXPECT_EQ(back.cols, 640);
  EXPECT_EQ(back.rows, 480);
  EXPECT_GT(FindColour(back, kPlotGroundTruthBgr, 0, back.rows).count, 300);  // PNG is lossless
  EXPECT_THROW(WritePng((dir / "missing" / "x.png").string(), back), std::runtime_error);
}

TEST(TrajectoryPlot, EmptyInputsDoNotCrash) {
  const cv::Mat top = RenderTopView(TopViewInput{});
  EXPECT_EQ(top.cols, TopViewOptions{}.width);
  TopViewInput only_est;
  only_est.series.push_back({"front", {}, {}});
  only_est.series.push_back({"merged", {{kT0, Se3()}}, {3}});
  EXPECT_FALSE(RenderTopView(only_est).empty());
  TopViewInput one_gt;
  one_gt.ground_truth.push_back({kT0, Se3()});
  one_gt.series.push_back({"front", {{kT0, Se3()}}, {}});
  EXPECT_FALSE(RenderTopView(one_gt).empty());
  const cv::Mat tl = RenderTimeline(TimelineInput{});
  EXPECT_EQ(tl.cols, TimelineOptions{}.width);
  EXPECT_EQ(tl.rows, TimelineOptions{}.height);
  TopViewOptions bad;
  bad.width = 10;
  EXPECT_THROW(RenderTopView(Scene(), bad), std::invalid_argument);
}

TimelineInput Fig6Like() {
  // 100 frames: tracking 0-49 (submap 0), lost 50-59, initializing 60-64 and
  // tracking 65-99 (submap 1). Samples: S1 every 5th before the loss, S2 all
  // lost/initialising frames, S3 every 5th after the resume.
  TimelineInput in;
  for (int i = 0; i < 100; ++i) {
    TimelineFrame f;
    f.t = kT0 + i * kDt;
    f.state = i < 50 ? TrackingState::kTracking
                     : i < 60 ? TrackingState::kLost
                              : i < 65 ? TrackingState::kInitializing : TrackingState::kTracking;
    f.submap_id = i < 50 ? 0 : i < 60 ? -1 : 1;
    in.frames.push_back(f);
    if (i < 50 && i >= 30 && i % 5 == 0) in.samples.push_back({f.t, 1, 0});
    if (i >= 50 && i < 65) in.samples.push_back({f.t, 2, 0});
    if (i >= 65 && i < 80 && i % 5 == 0) in.samples.push_back({f.t, 3, 0});
  }
  in.windows = WindowSpans(in.samples);
  return in;
}

TEST(TrajectoryPlot, TimelineShowsStatesWhereTheyHappen) {
  TimelineOptions o;
  const cv::Mat img = RenderTimeline(Fig6Like(), o);
  ASSERT_EQ(img.cols, o.width);
  ASSERT_EQ(img.rows, o.height);
  const int below_legend = 32;
  const ColourBox lost = FindColour(img, TrackingStateBgr(TrackingState::kLost), below_legend, img.rows);
  const ColourBox tracking = FindColour(img, TrackingStateBgr(TrackingState::kTracking), below_legend, img.rows);
  const ColourBox init = FindColour(img, TrackingStateBgr(TrackingState::kInitializing), below_legend, img.rows);
  ASSERT_GT(lost.count, 100);
  ASSERT_GT(init.count, 50);
  EXPECT_GT(tracking.count, lost.count);
  // Frames span 4.95 s on [120, width-20]: lost 2.5..3.0 s, then initialising.
  const double px_per_s = (o.width - 140) / 4.95;
  EXPECT_NEAR(lost.box.x, 120 + 2.5 * px_per_s, 2);
  EXPECT_NEAR(lost.box.x + lost.box.width, 120 + 3.0 * px_per_s, 2);
  EXPECT_NEAR(init.box.x, 120 + 3.0 * px_per_s, 2);
  // Sample ticks: S2 only inside the loss, S1 before it, S3 after.
  const ColourBox s2 = FindColour(img, SampleSetBgr(2), below_legend, img.rows);
  ASSERT_GT(s2.count, 0);
  EXPECT_GE(s2.box.x, lost.box.x - 2);
  EXPECT_LE(s2.box.x + s2.box.width, init.box.x + init.box.width + 2);
  const ColourBox s3 = FindColour(img, SampleSetBgr(3), below_legend, img.rows);
  ASSERT_GT(s3.count, 0);
  EXPECT_GT(s3.box.x, init.box.x + init.box.width - 2);
  // Submap row: colours of submap 0 and 1 appear.
  EXPECT_GT(FindColour(img, SubmapBgr(1), below_legend, img.rows).count, 100);
}

// Frames the replay dropped (front too slow) are not tracking failures: grey,
// with a legend entry, and no red where they are.
TEST(TrajectoryPlot, TimelineDrawsReplaySkippedFramesGrey) {
  TimelineInput in = Fig6Like();
  for (int i = 20; i < 25; ++i) {
    in.frames[i].state = TrackingState::kLost;
    in.frames[i].skipped = true;
  }
  const cv::Mat img = RenderTimeline(in);
  const int below_legend = 32;
  // In the state row (the top quarter under the legend; the submap row below
  // is grey where no submap is, and anti-aliased text has grey pixels).
  const ColourBox grey = FindColour(img.colRange(120, img.cols), kPlotNoSubmapBgr, below_legend, img.rows / 4);
  const double px_per_s = (img.cols - 140) / 4.95;
  ASSERT_GT(grey.count, 50);
  EXPECT_NEAR(120 + grey.box.x, 120 + 20 * 0.05 * px_per_s, 2);
  const ColourBox lost = FindColour(img, TrackingStateBgr(TrackingState::kLost), below_legend, img.rows);
  EXPECT_NEAR(lost.box.x, 120 + 2.5 * px_per_s, 2);  // only the real loss is red
  EXPECT_GT(FindColour(img, kPlotNoSubmapBgr, 0, below_legend).count, 0);  // legend entry
}

TEST(TrajectoryPlot, ZoomedTimelineStaysInsideThePlot) {
  TimelineInput in = Fig6Like();
  in.begin = kT0 + 45 * kDt;  // inside window 0 and submap 0
  in.end = kT0 + 70 * kDt;
  const cv::Mat img = RenderTimeline(in);
  const ColourBox s0 = FindColour(img, SubmapBgr(0), 32, img.rows);
  ASSERT_GT(s0.count, 0);
  EXPECT_GE(s0.box.x, 120);  // nothing spills into the row labels
  // Lost (frames 50..59) starts at 5/25 of the plot width.
  const ColourBox lost = FindColour(img, TrackingStateBgr(TrackingState::kLost), 32, img.rows);
  EXPECT_NEAR(lost.box.x, 120 + 0.2 * (img.cols - 140), 2);
  // The last S1 sample (frame 45) is the left edge.
  const ColourBox s1 = FindColour(img, SampleSetBgr(1), 32, img.rows);
  ASSERT_GT(s1.count, 0);
  EXPECT_GE(s1.box.x, 120);
  EXPECT_LE(s1.box.x + s1.box.width, 124);
}

TEST(TrajectoryPlot, WindowSpansAndSubmapLookup) {
  const std::vector<TimelineSample> samples = {
      {kT0 + 5, 1, 0}, {kT0 + 1, 2, 0}, {kT0 + 9, 3, 0}, {kT0 + 20, 1, 1}};
  const auto spans = WindowSpans(samples);
  ASSERT_EQ(spans.size(), 2u);
  EXPECT_EQ(spans[0].id, 0);
  EXPECT_EQ(spans[0].begin, kT0 + 1);
  EXPECT_EQ(spans[0].end, kT0 + 9);
  EXPECT_EQ(spans[1].begin, kT0 + 20);
  EXPECT_EQ(spans[1].end, kT0 + 20);

  const TimelineInput tl = Fig6Like();
  Trajectory poses = {{kT0 + 10 * kDt, Se3()}, {kT0 + 70 * kDt + 200, Se3()},
                      {kT0 + 55 * kDt, Se3()}, {kT0 + 500 * kDt, Se3()}};
  const auto ids = SubmapIdsByTime(poses, tl.frames);
  EXPECT_EQ(ids, (std::vector<int64_t>{0, 1, -1, -1}));
}

}  // namespace
}  // namespace rumi

namespace rumi {
namespace {
// Writes the test scenes to $RUMI_PLOT_DUMP (for looking at them).
TEST(TrajectoryPlot, DumpWhenAsked) {
  const char* dir = std::getenv("RUMI_PLOT_DUMP");
  if (!dir) GTEST_SKIP() << "set RUMI_PLOT_DUMP=DIR to write the plots";
  WritePng(std::string(dir) + "/top.png", RenderTopView(Scene()));
  WritePng(std::string(dir) + "/timeline.png", RenderTimeline(Fig6Like()));
}
}  // namespace
}  // namespace rumi
