// Dataset readers on the real sequences in shared/data (read-only).
#include <gtest/gtest.h>

#include <cmath>

#include "common/dataset.h"
#include "common/dataset_util.h"
#include "common/trajectory.h"

namespace rumi {
namespace {

const std::string kData = RUMI_SHARED_DATA_DIR;

struct Summary {
  size_t frames = 0;
  size_t with_gt = 0;
  Timestamp first = -1, last = -1;
  std::vector<Frame> kept;  // frames whose index is in keep
};

Summary ReadAll(FrameSource* src, const std::vector<size_t>& keep = {}) {
  Summary s;
  Frame f;
  Timestamp prev = std::numeric_limits<Timestamp>::min();
  while (src->Next(&f)) {
    EXPECT_GT(f.timestamp, prev) << f.path;
    prev = f.timestamp;
    EXPECT_EQ(f.image.type(), CV_8UC1) << f.path;
    EXPECT_EQ(f.image.cols, src->camera().width()) << f.path;
    EXPECT_EQ(f.image.rows, src->camera().height()) << f.path;
    if (s.frames == 0) s.first = f.timestamp;
    s.last = f.timestamp;
    if (f.T_wc_gt) ++s.with_gt;
    for (size_t k : keep)
      if (k == s.frames) s.kept.push_back(f);
    ++s.frames;
  }
  return s;
}

void ExpectPose(const Se3& T, double tx, double ty, double tz, double qx, double qy, double qz, double qw,
                double tol = 1e-9) {
  EXPECT_NEAR(T.translation().x(), tx, tol);
  EXPECT_NEAR(T.translation().y(), ty, tol);
  EXPECT_NEAR(T.translation().z(), tz, tol);
  const Eigen::Quaterniond q(qw, qx, qy, qz);
  // Quaternions from files are rounded; compare rotations by angle.
  EXPECT_LT(RotationAngle(T.rotation().inverse() * q.normalized()), 1e-6 + tol);
}

TEST(DatasetReal, TumFr3Sparse) {
  DatasetOptions o;
  o.kind = DatasetKind::kTum;
  o.path = kData + "/tum_fr3_office_sparse17";
  auto src = OpenDataset(o);  // camera picked from "fr3" in the folder name
  EXPECT_EQ(src->camera().fx(), 535.4);
  EXPECT_EQ(src->camera().fy(), 539.2);
  EXPECT_EQ(src->camera().cx(), 320.1);
  EXPECT_EQ(src->camera().cy(), 247.6);
  EXPECT_FALSE(src->camera().HasDistortion());
  EXPECT_EQ(src->camera().width(), 640);
  EXPECT_EQ(src->camera().height(), 480);
  ASSERT_EQ(src->size(), 17u);
  EXPECT_EQ(src->timestamps().front(), 1341847980722988000LL);
  EXPECT_EQ(src->timestamps().back(), 1341847996874766000LL);
  EXPECT_EQ(src->ground_truth().size(), 8710u);
  EXPECT_EQ(src->ground_truth().front().first, 1341847980790000000LL);
  const Summary s = ReadAll(src.get(), {0, 16});
  EXPECT_EQ(s.frames, 17u);
  EXPECT_EQ(src->skipped(), 0u);
  EXPECT_EQ(s.first, 1341847980722988000LL);
  EXPECT_EQ(s.last, 1341847996874766000LL);
  // The first image is 67 ms before the first ground-truth pose: no pose.
  ASSERT_EQ(s.kept.size(), 2u);
  EXPECT_FALSE(s.kept[0].T_wc_gt.has_value());
  EXPECT_EQ(s.with_gt, 16u);
  // Last image 1341847996.874766: nearest pose is .8699 (4.9 ms), not .8800 (5.2 ms).
  ASSERT_TRUE(s.kept[1].T_wc_gt.has_value());
  ExpectPose(*s.kept[1].T_wc_gt, 1.8092, -0.3743, 1.5701, 0.6981, 0.4942, -0.3065, -0.4178);
  EXPECT_NE(s.kept[1].path.find("1341847996.874766.png"), std::string::npos);

  // Rewind replays the same sequence.
  src->Rewind();
  Frame f;
  ASSERT_TRUE(src->Next(&f));
  EXPECT_EQ(f.timestamp, 1341847980722988000LL);
}

TEST(DatasetReal, TumAssociationRespectsMaxDiff) {
  DatasetOptions o;
  o.kind = DatasetKind::kTum;
  o.path = kData + "/tum_fr3_office_sparse17";
  o.max_diff_s = 0.004;  // last image is 4.866 ms from its nearest pose
  auto src = OpenDataset(o);
  const Summary s = ReadAll(src.get(), {16});
  ASSERT_EQ(s.kept.size(), 1u);
  EXPECT_FALSE(s.kept[0].T_wc_gt.has_value());
}

TEST(DatasetReal, EurocMicro) {
  DatasetOptions o;
  o.kind = DatasetKind::kEuroc;
  o.path = kData + "/euroc_v101_micro";
  auto src = OpenDataset(o);
  const PinholeCamera& cam = src->camera();
  EXPECT_EQ(cam.width(), 752);
  EXPECT_EQ(cam.height(), 480);
  EXPECT_EQ(cam.fx(), 458.654);
  EXPECT_EQ(cam.fy(), 457.296);
  EXPECT_EQ(cam.cx(), 367.215);
  EXPECT_EQ(cam.cy(), 248.375);
  EXPECT_EQ(cam.options().k1, -0.28340811);
  EXPECT_EQ(cam.options().k2, 0.07395907);
  EXPECT_EQ(cam.options().p1, 0.00019359);
  EXPECT_EQ(cam.options().p2, 1.76187114e-05);
  EXPECT_EQ(cam.options().k3, 0.0);
  ASSERT_EQ(src->size(), 95u);
  const Summary s = ReadAll(src.get(), {0, 94});
  EXPECT_EQ(s.frames, 95u);
  EXPECT_EQ(s.first, 1403715273262142976LL);  // ns exactly as in data.csv
  EXPECT_EQ(s.last, 1403715277962142976LL);
  EXPECT_EQ(s.with_gt, 95u);
  ASSERT_EQ(s.kept.size(), 2u);
  // groundtruth.txt (camera frame) line 3.
  ExpectPose(*s.kept[0].T_wc_gt, 0.863343, 2.246098, 0.924452, -0.656895, 0.507217, -0.353732, 0.431386);
  EXPECT_EQ(src->ground_truth().size(), 105u);
}

// T_w_cam = T_w_body * T_BS, checked against the camera-frame file that
// shared/data derived independently.
TEST(DatasetReal, EurocBodyToCameraThroughTBS) {
  PinholeCameraOptions cam;
  Se3 T_BS;
  ReadEurocSensorYaml(kData + "/euroc_v101_micro/mav0/cam0/sensor.yaml", &cam, &T_BS);
  EXPECT_NEAR(T_BS.translation().x(), -0.0216401454975, 1e-12);
  EXPECT_NEAR(T_BS.translation().y(), -0.064676986768, 1e-12);
  EXPECT_NEAR(T_BS.translation().z(), 0.00981073058949, 1e-12);
  EXPECT_NEAR(T_BS.R()(0, 1), -0.999880929698, 1e-6);
  EXPECT_NEAR(T_BS.R()(1, 0), 0.999557249008, 1e-6);
  const Trajectory body = ReadTumTrajectory(kData + "/euroc_v101_micro/groundtruth_body.txt");
  const Trajectory camf = ReadTumTrajectory(kData + "/euroc_v101_micro/groundtruth.txt");
  ASSERT_EQ(body.size(), camf.size());
  ASSERT_GT(body.size(), 100u);
  double worst_t = 0, worst_r = 0, wrong_order = 1e9;
  for (size_t i = 0; i < body.size(); ++i) {
    ASSERT_EQ(body[i].t, camf[i].t);
    const Se3 T = body[i].T_wc * T_BS;
    worst_t = std::max(worst_t, (T.translation() - camf[i].T_wc.translation()).norm());
    worst_r = std::max(worst_r, RotationAngle(T.rotation().inverse() * camf[i].T_wc.rotation()));
    const Se3 W = T_BS * body[i].T_wc;  // the wrong composition must not match
    wrong_order = std::min(wrong_order, (W.translation() - camf[i].T_wc.translation()).norm());
  }
  EXPECT_LT(worst_t, 2e-6);  // files hold 6 decimals
  EXPECT_LT(worst_r, 1e-5);
  EXPECT_GT(wrong_order, 0.01);
}

TEST(DatasetReal, Kitti03First400) {
  DatasetOptions o;
  o.kind = DatasetKind::kKitti;
  o.path = kData + "/kitti03_first400";
  auto src = OpenDataset(o);
  const PinholeCamera& cam = src->camera();
  EXPECT_EQ(cam.width(), 1242);
  EXPECT_EQ(cam.height(), 375);
  EXPECT_EQ(cam.fx(), 721.5377);
  EXPECT_EQ(cam.fy(), 721.5377);
  EXPECT_EQ(cam.cx(), 609.5593);
  EXPECT_EQ(cam.cy(), 172.854);
  EXPECT_FALSE(cam.HasDistortion());
  ASSERT_EQ(src->size(), 400u);
  const Summary s = ReadAll(src.get(), {0, 1, 399});
  EXPECT_EQ(s.frames, 400u);
  EXPECT_EQ(src->skipped(), 0u);
  EXPECT_EQ(s.first, 0);
  EXPECT_EQ(s.last, 41282760000LL);
  EXPECT_EQ(s.with_gt, 400u);
  ASSERT_EQ(s.kept.size(), 3u);
  EXPECT_EQ(s.kept[1].timestamp, 103391000LL);
  ExpectPose(*s.kept[0].T_wc_gt, 0, 0, 0, 0, 0, 0, 1);
  ExpectPose(*s.kept[2].T_wc_gt, 202.692400, -16.175980, 145.397600, 0.042793341, 0.590639858, -0.020585929,
             0.805536782);
}

TEST(DatasetReal, EcdSliderThroughFolderReader) {
  DatasetOptions o;
  o.kind = DatasetKind::kFolder;
  o.path = kData + "/ecd_slider_hdr_close";
  auto src = OpenDataset(o);
  const PinholeCameraOptions& c = src->camera().options();
  EXPECT_EQ(c.width, 240);
  EXPECT_EQ(c.height, 180);
  EXPECT_EQ(c.fx, 335.419462958);
  EXPECT_EQ(c.fy, 335.352935612);
  EXPECT_EQ(c.cx, 129.924663379);
  EXPECT_EQ(c.cy, 99.1864303447);
  EXPECT_EQ(c.k1, -0.138592767408);
  EXPECT_EQ(c.k2, 0.0933736664192);
  EXPECT_EQ(c.p1, -0.000335586987532);
  EXPECT_EQ(c.p2, 0.000173720158228);
  EXPECT_EQ(c.k3, 0.0);
  ASSERT_EQ(src->size(), 149u);
  const Summary s = ReadAll(src.get(), {0});
  EXPECT_EQ(s.frames, 149u);
  EXPECT_EQ(s.first, 1270000LL);
  EXPECT_EQ(s.last, 6522943999LL);
  EXPECT_EQ(src->ground_truth().size(), 654u);  // no comment lines in this file
  // Image 0.001270 s: nearest pose is the first one at 0.012753562 (11.5 ms).
  ASSERT_TRUE(s.kept[0].T_wc_gt.has_value());
  ExpectPose(*s.kept[0].T_wc_gt, 0.100087239583, 0, 0, 0, 0, 0, 1);
  EXPECT_EQ(s.with_gt, 149u);
}

}  // namespace
}  // namespace rumi
