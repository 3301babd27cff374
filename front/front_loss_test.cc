// Loss handling and the hierarchical mode on the real KITTI excerpt with
// black / noise frames cut into it.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <random>

#include "front/front.h"
#include "front/front_publisher.h"
#include "front/testing/front_test_util.h"
#include "common/testing/require.h"

namespace rumi {
namespace {

cv::Mat Noise(const cv::Size& sz, unsigned seed) {
  cv::Mat m(sz, CV_8U);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

TEST(FrontLoss, BlackAndNoiseFramesStartANewSubmapWithinOneSecond) {
  auto seq = LoadKitti(76);
  RUMI_REQUIRE(seq, "KITTI excerpt not found");
  FrontOptions o;
  o.local_mapping_thread = false;
  o.local_ba_max_time_s = 60;  // no wall-clock cut: same result on a loaded CI machine
  Front front(o, seq->camera);
  front.LimitHistory(10);
  Timestamp t_loss = -1, t_new_submap = -1;
  int tracked_before = 0, tracked_after = 0;
  for (int i = 0; i < 76; ++i) {
    const Frame& f = seq->frames[i];
    cv::Mat img = f.image;
    const bool blind = i >= 35 && i < 42;
    if (blind) img = (i % 2) ? cv::Mat::zeros(f.image.size(), CV_8U) : Noise(f.image.size(), i);
    const FrameRecord r = front.Track(f.timestamp, img);
    if (i < 35 && r.state == TrackingState::kTracking) ++tracked_before;
    if (blind) {
      EXPECT_NE(r.state, TrackingState::kTracking) << "frame " << i;
    }
    if (blind && t_loss < 0) {
      t_loss = f.timestamp;
      EXPECT_EQ(r.submap_id, 0);
    }
    if (t_loss >= 0 && t_new_submap < 0 && r.submap_id > 0) t_new_submap = f.timestamp;
    if (i >= 42 && r.state == TrackingState::kTracking) {
      ++tracked_after;
      EXPECT_GE(r.submap_id, 1);
    }
  }
  EXPECT_GE(tracked_before, 28);
  ASSERT_GE(t_new_submap, 0) << "no new submap after the loss";
  EXPECT_LE(NsToSeconds(t_new_submap - t_loss), 1.0);
  EXPECT_GE(tracked_after, 20);  // re-initialised on the frames after the cut
  // The first submap was finished with its map; its frames stop at the loss.
  ASSERT_GE(front.FinishedSubmaps().size(), 1u);
  const Submap& s0 = front.FinishedSubmaps()[0];
  EXPECT_EQ(s0.id, 0);
  EXPECT_GE(s0.keyframes.size(), 5u);
  EXPECT_GT(s0.points.size(), 200u);
  for (const FrameRecord& r : s0.frames) EXPECT_LE(r.timestamp, t_new_submap);
  const AteSummary ate = Ate(s0.frames, seq->frames);
  EXPECT_LT(ate.Percent(), 1.5);
  front.Finish();
  EXPECT_GE(front.FinishedSubmaps().size(), 2u);
  EXPECT_GT(front.FinishedSubmaps().back().id, 0);
  // Bounded for a day-long run: the newest records and timings only...
  EXPECT_LE(front.records().size(), 20u);
  EXPECT_EQ(front.timings().size(), front.records().size());
  EXPECT_EQ(front.records().back().timestamp, seq->frames[75].timestamp);
  // ...and once the publisher has them, the finished submaps keep their
  // keyframe poses, and frame records only where front.txt comes from.
  const std::vector<Submap>& fin = front.FinishedSubmaps();
  const int largest = LargestFrontSubmap(fin);
  ASSERT_GE(largest, 0);
  const size_t largest_tracked = TrackedFrames(fin[largest]);
  std::vector<size_t> keyframes;
  for (const Submap& s : fin) keyframes.push_back(s.keyframes.size());
  front.TrimFinished(fin.size());
  EXPECT_EQ(LargestFrontSubmap(fin), largest);
  EXPECT_EQ(TrackedFrames(fin[largest]), largest_tracked);
  // Freed, not only cleared (a cleared vector keeps its buffer).
  for (size_t i = 0; i < fin.size(); ++i) {
    EXPECT_EQ(fin[i].points.capacity(), 0u);
    EXPECT_EQ(fin[i].keyframes.size(), keyframes[i]);
    for (const Keyframe& kf : fin[i].keyframes) {
      EXPECT_EQ(kf.keypoints.capacity() + kf.point_ids.capacity() + kf.octaves.capacity(), 0u);
      EXPECT_TRUE(kf.descriptors.empty());
    }
    if (static_cast<int>(i) != largest) {
      EXPECT_EQ(fin[i].frames.capacity(), 0u) << "submap " << fin[i].id;
    }
  }
}

TEST(FrontLoss, DroppedFramesRelocaliseOrRestartWithinOneSecond) {
  auto seq = LoadKitti(70);
  RUMI_REQUIRE(seq, "KITTI excerpt not found");
  FrontOptions o;
  o.local_mapping_thread = false;
  o.local_ba_max_time_s = 60;  // no wall-clock cut: same result on a loaded CI machine
  Front front(o, seq->camera);
  Timestamp t_back = -1;
  std::vector<FrameRecord> after;
  for (int i = 0; i < 70; ++i) {
    if (i >= 36 && i < 41) continue;  // 0.5 s of frames lost on the link (~3.5 m driven)
    const FrameRecord r = front.Track(seq->frames[i].timestamp, seq->frames[i].image);
    if (i >= 41) after.push_back(r);
  }
  // Tracking again (relocalised in submap 0, or a new submap) within 1 s.
  for (const FrameRecord& r : after)
    if (r.state == TrackingState::kTracking) { t_back = r.timestamp; break; }
  ASSERT_GE(t_back, 0);
  EXPECT_LE(NsToSeconds(t_back - seq->frames[41].timestamp), 1.0);
  int tracked = 0;
  for (const FrameRecord& r : after) tracked += r.state == TrackingState::kTracking ? 1 : 0;
  EXPECT_GE(tracked, static_cast<int>(after.size()) - 12);
  // No wrong lock across the gap: each submap stays consistent with the truth.
  front.Finish();
  for (const Submap& s : front.FinishedSubmaps()) {
    const AteSummary ate = Ate(s.frames, seq->frames);
    if (ate.pairs >= 10) {
      EXPECT_LT(ate.Percent(), 1.5) << "submap " << s.id;
    }
  }
}

TEST(FrontLoss, HierarchicalCoarseStateChainsSubmapsByPosePrior) {
  auto seq = LoadKitti(66);
  RUMI_REQUIRE(seq, "KITTI excerpt not found");
  FrontOptions o;
  o.local_mapping_thread = false;
  o.local_ba_max_time_s = 60;  // no wall-clock cut: same result on a loaded CI machine
  o.hierarchical = true;
  o.hier.eta = 3.0;  // KITTI frames: ~40 keypoints per 100x100 px
  o.hier.sparse_frames = 3;
  o.hier.resume_frames = 3;
  // The odometry stand-in gives body poses; the camera sits 0.3 m up, turned.
  o.odometry_T_bc = Se3(Eigen::Quaterniond(Eigen::AngleAxisd(1.2, Eigen::Vector3d(1, 1, 0).normalized())),
                        Eigen::Vector3d(0.1, -0.2, 0.3));
  Front front(o, seq->camera);
  std::map<Timestamp, Se3> gt;
  for (const Frame& f : seq->frames) {
    ASSERT_TRUE(f.T_wc_gt);
    front.AddPosePrior(f.timestamp, *f.T_wc_gt * o.odometry_T_bc.Inverse());  // body pose
    gt[f.timestamp] = *f.T_wc_gt;
  }
  int coarse = 0, halted = 0, tracked_after = 0;
  for (int i = 0; i < 66; ++i) {
    const Frame& f = seq->frames[i];
    const bool dark = i >= 30 && i < 36;
    const FrameRecord r = front.Track(f.timestamp, dark ? cv::Mat::zeros(f.image.size(), CV_8U) : f.image);
    if (i < 30) {
      EXPECT_EQ(front.grain(), MappingGrain::kFine);
    }
    if (i == 31) {
      EXPECT_EQ(front.grain(), MappingGrain::kFine);  // 2 sparse frames: not yet
    }
    if (i == 32) {  // third sparse frame: coarse, submap 0 finished
      EXPECT_EQ(front.grain(), MappingGrain::kCoarse);
      EXPECT_EQ(front.FinishedSubmaps().size(), 1u);
    }
    if (r.state == TrackingState::kCoarse) {
      ++coarse;
      EXPECT_EQ(r.submap_id, 0);
    }
    halted += front.halt() ? 1 : 0;
    if (i >= 38 && r.state == TrackingState::kTracking) {
      ++tracked_after;
      EXPECT_EQ(r.submap_id, 1);
    }
  }
  // Coarse from the 3rd dark frame until the 3rd dense one after it.
  EXPECT_EQ(coarse, 4 + 2);
  EXPECT_EQ(halted, coarse);
  EXPECT_GE(tracked_after, 20);
  // The pose source bridges the coarse stretch: the last pose of submap 0
  // and the first of submap 1 give the motion the manager chains them with.
  ASSERT_EQ(front.FinishedSubmaps().size(), 1u);
  const Submap& before = front.FinishedSubmaps()[0];
  const Submap after = front.CurrentSubmap();
  ASSERT_FALSE(before.odometry.empty());
  ASSERT_FALSE(after.odometry.empty());
  EXPECT_LT(before.odometry.back().timestamp, seq->frames[32].timestamp);
  EXPECT_GE(after.odometry.front().timestamp, seq->frames[32].timestamp);
  const Se3 moved = before.odometry.back().T_wb.Inverse() * after.odometry.front().T_wb;
  EXPECT_GT(moved.translation().norm(), 1.0);  // the car moved on meanwhile
  // Each submap carries the pose source at its frames (the manager's odometry
  // merge), as camera poses.
  for (const Submap& s : front.FinishedSubmaps()) {
    ASSERT_EQ(s.odometry.size(), s.frames.size()) << "submap " << s.id;
    for (size_t i = 0; i < s.frames.size(); ++i) {
      EXPECT_EQ(s.odometry[i].timestamp, s.frames[i].timestamp);
      EXPECT_LT((s.odometry[i].T_wb.translation() - gt[s.frames[i].timestamp].translation()).norm(), 1e-9);
      EXPECT_LT(s.odometry[i].T_wb.rotation().angularDistance(gt[s.frames[i].timestamp].rotation()), 1e-9);
    }
  }
}

}  // namespace
}  // namespace rumi
