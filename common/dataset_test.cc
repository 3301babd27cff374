// Dataset readers on small generated folders: layouts, errors, skipping.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "common/dataset.h"
#include "common/dataset_util.h"
#include "common/testing/temp_dir.h"
#include "common/trajectory.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;
const std::string kData = RUMI_SHARED_DATA_DIR;

void WriteText(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path) << text;
}

// Grey image whose pixel (0,0) encodes k, so tests can tell frames apart.
void WriteImage(const std::string& path, int k, int w = 64, int h = 48) {
  fs::create_directories(fs::path(path).parent_path());
  cv::Mat img(h, w, CV_8U, cv::Scalar(100));
  img.at<uint8_t>(0, 0) = static_cast<uint8_t>(k);
  ASSERT_TRUE(cv::imwrite(path, img));
}

// rgb.txt with n frames at 0.1 s + 0.05 s * i and images 64x48.
void MakeFolder(const TempDir& d, int n, bool calib = true) {
  std::string rgb = "# timestamp filename\n";
  for (int i = 0; i < n; ++i) {
    const std::string name = "images/" + std::to_string(i) + ".png";
    WriteImage(d / name, i);
    rgb += FormatSeconds(100000000LL + 50000000LL * i) + " " + name + "\n";
  }
  WriteText(d / "rgb.txt", rgb);
  if (calib) WriteText(d / "calib.txt", "50 51 31.5 23.5\n");
}

std::string ErrorOf(const DatasetOptions& o) {
  try {
    OpenDataset(o);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

DatasetOptions FolderOptions(const TempDir& d) {
  DatasetOptions o;
  o.kind = DatasetKind::kFolder;
  o.path = d.str();
  return o;
}

TEST(DatasetOptions, KindAndCheck) {
  DatasetKind k;
  EXPECT_TRUE(ParseDatasetKind("tum", &k));
  EXPECT_EQ(k, DatasetKind::kTum);
  EXPECT_TRUE(ParseDatasetKind("EuRoC", &k));
  EXPECT_EQ(k, DatasetKind::kEuroc);
  EXPECT_TRUE(ParseDatasetKind("icl_nuim", &k));
  EXPECT_EQ(k, DatasetKind::kIcl);
  EXPECT_TRUE(ParseDatasetKind("kitti", &k));
  EXPECT_EQ(k, DatasetKind::kKitti);
  EXPECT_TRUE(ParseDatasetKind("folder", &k));
  EXPECT_EQ(k, DatasetKind::kFolder);
  EXPECT_FALSE(ParseDatasetKind("tumm", &k));
  DatasetOptions o;
  EXPECT_FALSE(o.Check());  // no path
  o.path = "/x";
  EXPECT_TRUE(o.Check());
  o.max_diff_s = 0;
  EXPECT_FALSE(o.Check());
  o.max_diff_s = std::nan("");
  EXPECT_FALSE(o.Check());
  o.max_diff_s = 0.02;
  o.path = "/nonexistent/rumi_dataset";
  EXPECT_NE(ErrorOf(o).find("/nonexistent/rumi_dataset"), std::string::npos);
}

TEST(DatasetFolder, ReadsFramesInOrderWithCalibTxt) {
  const TempDir d;
  d.Create();
  MakeFolder(d, 5);
  WriteText(d / "groundtruth.txt",
            "# t tx ty tz qx qy qz qw\n"
            "0.100 1 0 0 0 0 0 1\n"
            "0.155 2 0 0 0 0 0 1\n"    // 5 ms after frame 1
            "0.155 9 0 0 0 0 0 1\n"    // a duplicated stamp (TUM fr2_desk has one): the first counts
            "0.300 3 0 0 0 0 0 1\n");  // frame 4 at 0.300 exactly; frames 2, 3 too far
  auto src = OpenDataset(FolderOptions(d));
  EXPECT_EQ(src->camera().width(), 64);  // from the first image
  EXPECT_EQ(src->camera().height(), 48);
  EXPECT_EQ(src->camera().fx(), 50);
  EXPECT_EQ(src->camera().fy(), 51);
  EXPECT_EQ(src->camera().cx(), 31.5);
  EXPECT_EQ(src->camera().cy(), 23.5);
  ASSERT_EQ(src->size(), 5u);
  Frame f;
  std::vector<double> gt_x;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(src->Next(&f));
    EXPECT_EQ(f.timestamp, 100000000LL + 50000000LL * i);
    EXPECT_EQ(f.image.at<uint8_t>(0, 0), i);
    gt_x.push_back(f.T_wc_gt ? f.T_wc_gt->translation().x() : -1.0);
  }
  EXPECT_FALSE(src->Next(&f));
  EXPECT_EQ(gt_x, (std::vector<double>{1, 2, -1, -1, 3}));
  src->Rewind();
  ASSERT_TRUE(src->Next(&f));
  EXPECT_EQ(f.image.at<uint8_t>(0, 0), 0);
}

TEST(DatasetFolder, CorruptAndWrongSizeImagesAreSkipped) {
  const TempDir d;
  d.Create();
  MakeFolder(d, 5);
  WriteText(d / "images/1.png", "\x89PNG\r\n\x1a\n this is not a png");
  WriteImage(d / "images/3.png", 3, 32, 24);  // wrong size
  fs::remove(d / "images/4.png");             // missing
  auto src = OpenDataset(FolderOptions(d));
  EXPECT_EQ(src->size(), 5u);
  EXPECT_EQ(src->timestamps().size(), 5u);
  Frame f;
  std::vector<int> seen;
  while (src->Next(&f)) seen.push_back(f.image.at<uint8_t>(0, 0));
  EXPECT_EQ(seen, (std::vector<int>{0, 2}));
  EXPECT_EQ(src->skipped(), 3u);
}

TEST(DatasetFolder, DuplicateTimestampRejectedWithLine) {
  const TempDir d;
  d.Create();
  MakeFolder(d, 3);
  WriteText(d / "rgb.txt", "# header\n0.1 images/0.png\n0.15 images/1.png\n0.150000 images/2.png\n");
  const std::string e = ErrorOf(FolderOptions(d));
  EXPECT_NE(e.find("rgb.txt:4"), std::string::npos) << e;
  EXPECT_NE(e.find("duplicates"), std::string::npos) << e;
}

TEST(DatasetFolder, UnsortedTimestampRejectedWithLine) {
  const TempDir d;
  d.Create();
  MakeFolder(d, 3);
  WriteText(d / "rgb.txt", "0.1 images/0.png\n\n0.3 images/1.png\n0.2 images/2.png\n");
  const std::string e = ErrorOf(FolderOptions(d));
  EXPECT_NE(e.find("rgb.txt:4"), std::string::npos) << e;
  EXPECT_NE(e.find("before"), std::string::npos) << e;
}

TEST(DatasetFolder, MalformedLinesRejectedWithLine) {
  const TempDir d;
  d.Create();
  MakeFolder(d, 2);
  WriteText(d / "rgb.txt", "0.1 images/0.png\n0.2x images/1.png\n");
  std::string e = ErrorOf(FolderOptions(d));
  EXPECT_NE(e.find("rgb.txt:2"), std::string::npos) << e;
  EXPECT_NE(e.find("0.2x"), std::string::npos) << e;
  WriteText(d / "rgb.txt", "0.1 images/0.png\n0.2\n");
  e = ErrorOf(FolderOptions(d));
  EXPECT_NE(e.find("rgb.txt:2"), std::string::npos) << e;
  WriteText(d / "rgb.txt", "# nothing\n");
  e = ErrorOf(FolderOptions(d));
  EXPECT_NE(e.find("no images"), std::string::npos) << e;
  // Malformed ground truth: file and line from the trajectory reader.
  WriteText(d / "rgb.txt", "0.1 images/0.png\n");
  WriteText(d / "groundtruth.txt", "0.1 0 0 0 0 0 0 1\n0.2 0 0 0 0 0 1\n");
  e = ErrorOf(FolderOptions(d));
  EXPECT_NE(e.find("groundtruth.txt:2"), std::string::npos) << e;
}

TEST(DatasetFolder, MissingIndexOrCameraNamed) {
  const TempDir d;
  d.Create();
  MakeFolder(d, 2, /*calib=*/false);
  std::string e = ErrorOf(FolderOptions(d));
  EXPECT_NE(e.find("calib.txt"), std::string::npos) << e;
  fs::remove(d / "rgb.txt");
  e = ErrorOf(FolderOptions(d));
  EXPECT_NE(e.find("rgb.txt"), std::string::npos) << e;
  EXPECT_NE(e.find("not found"), std::string::npos) << e;
}

TEST(DatasetFolder, ConfigCameraOverridesCalib) {
  const TempDir d;
  d.Create();
  MakeFolder(d, 2);
  WriteText(d / "cam.yaml", "camera:\n  fx: 70\n  fy: 71\n  cx: 30\n  cy: 20\n  k1: -0.1\n");
  DatasetOptions o = FolderOptions(d);
  o.config_path = d / "cam.yaml";
  auto src = OpenDataset(o);
  EXPECT_EQ(src->camera().fx(), 70);
  EXPECT_EQ(src->camera().options().k1, -0.1);
  EXPECT_EQ(src->camera().width(), 64);  // size not in the config: from the images
  // A config without a camera section falls back to calib.txt.
  WriteText(d / "other.yaml", "log_level: info\n");
  o.config_path = d / "other.yaml";
  EXPECT_EQ(OpenDataset(o)->camera().fx(), 50);
  // A config that sets a size the images do not have: refused at open (it
  // used to skip every frame and let the run "succeed" with nothing tracked).
  WriteText(d / "cam.yaml", "camera: {width: 640, height: 480, fx: 70, fy: 71, cx: 30, cy: 20}\n");
  o.config_path = d / "cam.yaml";
  EXPECT_NE(ErrorOf(o).find("the camera is 640x480 but the images of"), std::string::npos) << ErrorOf(o);
  EXPECT_NE(ErrorOf(o).find("are 64x48"), std::string::npos) << ErrorOf(o);
  // Not one readable image: refused at open, naming the first.
  for (int i = 0; i < 2; ++i) WriteText(d / ("images/" + std::to_string(i) + ".png"), "not a png");
  WriteText(d / "cam.yaml", "camera: {fx: 70, fy: 71, cx: 30, cy: 20}\n");
  EXPECT_NE(ErrorOf(o).find("no readable image among the 2 listed"), std::string::npos) << ErrorOf(o);
  // Invalid camera in the config: ConfigError naming the file.
  WriteText(d / "bad.yaml", "camera: {fx: 0}\n");
  o.config_path = d / "bad.yaml";
  EXPECT_NE(ErrorOf(o).find("bad.yaml"), std::string::npos) << ErrorOf(o);
}

TEST(DatasetUtil, CalibTxtFormats) {
  const TempDir d;
  d.Create();
  PinholeCameraOptions o;
  WriteText(d / "c9.txt", "# fx fy cx cy k1 k2 p1 p2 k3\n1 2 3 4 0.1 0.2 0.3 0.4 0.5\n");
  ReadCalibTxt(d / "c9.txt", &o);
  EXPECT_EQ(o.fx, 1);
  EXPECT_EQ(o.fy, 2);
  EXPECT_EQ(o.cx, 3);
  EXPECT_EQ(o.cy, 4);
  EXPECT_EQ(o.k1, 0.1);
  EXPECT_EQ(o.k2, 0.2);
  EXPECT_EQ(o.p1, 0.3);
  EXPECT_EQ(o.p2, 0.4);
  EXPECT_EQ(o.k3, 0.5);
  WriteText(d / "kitti.txt",
            "P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 0.000000000000e+00 "
            "0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 "
            "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n"
            "P1: 7.188560000000e+02 0 6.071928000000e+02 -3.861448000000e+02 0 7.188560000000e+02 "
            "1.852157000000e+02 0 0 0 1 0\n");
  ReadCalibTxt(d / "kitti.txt", &o);
  EXPECT_EQ(o.fx, 718.856);
  EXPECT_EQ(o.fy, 718.856);
  EXPECT_EQ(o.cx, 607.1928);
  EXPECT_EQ(o.cy, 185.2157);
  EXPECT_EQ(o.k1, 0.0);
  EXPECT_EQ(o.k3, 0.0);
  WriteText(d / "bad.txt", "\n1 2 3\n");
  try {
    ReadCalibTxt(d / "bad.txt", &o);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.txt:2"), std::string::npos) << e.what();
  }
  WriteText(d / "bad2.txt", "1 2 3 x\n");
  EXPECT_THROW(ReadCalibTxt(d / "bad2.txt", &o), std::runtime_error);
  EXPECT_THROW(ReadCalibTxt(d / "none.txt", &o), std::runtime_error);
}

TEST(DatasetUtil, NearestPose) {
  GroundTruth gt;
  for (Timestamp t : {100, 200, 300}) gt.emplace_back(t, Se3());
  EXPECT_EQ(NearestPose(gt, 100, 0), 0);
  EXPECT_EQ(NearestPose(gt, 149, 60), 0);
  EXPECT_EQ(NearestPose(gt, 151, 60), 1);
  EXPECT_EQ(NearestPose(gt, 150, 60), 0);  // tie: earlier
  EXPECT_EQ(NearestPose(gt, 40, 60), 0);
  EXPECT_EQ(NearestPose(gt, 39, 60), -1);
  EXPECT_EQ(NearestPose(gt, 360, 60), 2);
  EXPECT_EQ(NearestPose(gt, 361, 60), -1);
  EXPECT_EQ(NearestPose(gt, 250, 40), -1);
  EXPECT_EQ(NearestPose(GroundTruth(), 250, 40), -1);
}

TEST(DatasetTum, CameraFromFolderNameOrConfig) {
  EXPECT_EQ(DetectTumFreiburg("/data/rgbd_dataset_freiburg1_xyz"), 1);
  EXPECT_EQ(DetectTumFreiburg("/data/rgbd_dataset_freiburg2_desk/"), 2);
  EXPECT_EQ(DetectTumFreiburg("tum_fr3_office"), 3);
  EXPECT_EQ(DetectTumFreiburg("/data/freiburg3/sequence"), 0);  // only the last name counts
  EXPECT_EQ(DetectTumFreiburg("office"), 0);
  EXPECT_EQ(TumCameraOptions(1).k3, 1.163314);
  EXPECT_EQ(TumCameraOptions(2).fx, 520.908620);
  EXPECT_THROW(TumCameraOptions(4), std::invalid_argument);

  const TempDir d;
  d.Create();
  MakeFolder(d, 2);
  DatasetOptions o;
  o.kind = DatasetKind::kTum;
  o.path = d.str();
  const std::string e = ErrorOf(o);
  EXPECT_NE(e.find("freiburg"), std::string::npos) << e;
  WriteText(d / "cam.yaml", "camera: {fx: 517.306408, fy: 516.469215, cx: 318.643040, cy: 255.313989}\n");
  o.config_path = d / "cam.yaml";
  // The size comes from the 64x48 images: that principal point lies outside.
  EXPECT_NE(ErrorOf(o).find("principal point (318.643040, 255.313989) lies outside the 64x48 image"),
            std::string::npos) << ErrorOf(o);
  for (int i = 0; i < 2; ++i) WriteImage(d / ("images/" + std::to_string(i) + ".png"), i, 640, 480);
  auto src = OpenDataset(o);
  EXPECT_EQ(src->camera().fx(), 517.306408);
  EXPECT_EQ(src->camera().width(), 640);
}

TEST(DatasetIcl, FakeFolderWithGtFreiburg) {
  const TempDir d;
  d.Create();
  std::string assoc;
  for (int i = 0; i < 5; ++i) {
    WriteImage(d / ("rgb/" + std::to_string(i) + ".png"), i, 640, 480);
    // Timestamps not equal to the frame number: the index maps by file name.
    const std::string t = FormatSeconds(1000000000LL + 33333333LL * i);
    assoc += t + " depth/" + std::to_string(i) + ".png " + t + " rgb/" + std::to_string(i) + ".png\n";
  }
  WriteText(d / "associations.txt", assoc);
  // Index 2 absent; quaternion x y z w order.
  WriteText(d / "livingRoom0.gt.freiburg",
            "0 0 0 -2.25 0 0 0 1\n"
            "1 0.1 0 -2.25 0 0 0 1\n"
            "3 0.3 0 -2.25 0 0 0.7071067811865476 0.7071067811865476\n"
            "4 0.4 0 -2.25 0 0 0 1\n");
  DatasetOptions o;
  o.kind = DatasetKind::kIcl;
  o.path = d.str();
  auto src = OpenDataset(o);
  EXPECT_EQ(src->camera().fx(), 481.2);
  EXPECT_EQ(src->camera().fy(), -480.0);
  EXPECT_EQ(src->camera().cx(), 319.5);
  EXPECT_EQ(src->camera().cy(), 239.5);
  ASSERT_EQ(src->size(), 5u);
  ASSERT_EQ(src->ground_truth().size(), 4u);
  EXPECT_EQ(src->ground_truth()[2].first, 1000000000LL + 33333333LL * 3);
  Frame f;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(src->Next(&f));
    EXPECT_EQ(f.image.at<uint8_t>(0, 0), i);  // the rgb column, not depth
    EXPECT_EQ(f.timestamp, 1000000000LL + 33333333LL * i);
    if (i == 2) {
      EXPECT_FALSE(f.T_wc_gt.has_value());
      continue;
    }
    ASSERT_TRUE(f.T_wc_gt.has_value()) << i;
    EXPECT_NEAR(f.T_wc_gt->translation().x(), 0.1 * i, 1e-12);
    EXPECT_NEAR(f.T_wc_gt->translation().z(), -2.25, 1e-12);
    if (i == 3) {  // 90 deg about z
      const Eigen::Vector3d x = f.T_wc_gt->R() * Eigen::Vector3d::UnitX();
      EXPECT_NEAR(x.y(), 1.0, 1e-9);
    }
  }
  // Decreasing indices are an error naming file and line.
  WriteText(d / "livingRoom0.gt.freiburg", "0 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n");
  const std::string e = ErrorOf(o);
  EXPECT_NE(e.find("livingRoom0.gt.freiburg:3"), std::string::npos) << e;
}

TEST(DatasetKitti, NativeLayout) {
  const TempDir root;  // kitti_native/sequences/07 and kitti_native/poses/07.txt in it
  const fs::path d = root.path() / "kitti_native/sequences/07";
  fs::create_directories(d);
  std::string times, poses;
  for (int i = 0; i < 4; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "image_0/%06d.png", i);
    WriteImage(d / name, i, 1226, 370);
    char t[64];
    std::snprintf(t, sizeof(t), "%e\n", 0.103751 * i);  // KITTI writes exponent notation
    times += t;
    poses += "1 0 0 " + std::to_string(i) + " 0 1 0 0 0 0 1 " + std::to_string(2 * i) + "\n";
  }
  WriteText(d / "times.txt", times);
  WriteText(d / "calib.txt",
            "P0: 7.070912e+02 0 6.018873e+02 0 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n"
            "P1: 7.070912e+02 0 6.018873e+02 -3.798145e+02 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n");
  DatasetOptions o;
  o.kind = DatasetKind::kKitti;
  o.path = d.string();
  {
    auto src = OpenDataset(o);  // no poses yet
    EXPECT_TRUE(src->ground_truth().empty());
    EXPECT_EQ(src->camera().fx(), 707.0912);
    EXPECT_EQ(src->camera().cy(), 183.1104);
    EXPECT_EQ(src->camera().width(), 1226);
  }
  // Official place of the poses: <root>/poses/<seq>.txt beside sequences/.
  WriteText(d.string() + "/../../poses/07.txt", poses);
  auto src = OpenDataset(o);
  ASSERT_EQ(src->size(), 4u);
  ASSERT_EQ(src->ground_truth().size(), 4u);
  Frame f;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(src->Next(&f));
    EXPECT_EQ(f.timestamp, SecondsToNs(0.103751 * i));
    EXPECT_EQ(f.image.at<uint8_t>(0, 0), i);
    ASSERT_TRUE(f.T_wc_gt.has_value());
    EXPECT_NEAR(f.T_wc_gt->translation().x(), i, 1e-12);
    EXPECT_NEAR(f.T_wc_gt->translation().z(), 2 * i, 1e-12);
  }
  // Pose count must match the frame count.
  WriteText(d / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_NE(ErrorOf(o).find("poses.txt"), std::string::npos) << ErrorOf(o);
  fs::remove(d / "times.txt");
  EXPECT_NE(ErrorOf(o).find("times.txt"), std::string::npos) << ErrorOf(o);
}

// Native EuRoC ground truth (body frame, csv with w x y z quaternions) goes
// through T_BS to the camera frame: compare with shared/data's camera file.
TEST(DatasetEuroc, NativeBodyGroundTruthCsv) {
  const std::string src_dir = kData + "/euroc_v101_micro";
  const TempDir d;
  d.Create();
  fs::create_directories(d / "mav0/cam0/data");
  fs::copy_file(src_dir + "/mav0/cam0/sensor.yaml", d / "mav0/cam0/sensor.yaml");
  std::ifstream csv_in(src_dir + "/mav0/cam0/data.csv");
  std::string line, csv;
  int n = 0;
  while (std::getline(csv_in, line) && n < 4) {
    csv += line + "\n";
    if (line[0] == '#') continue;
    const std::string name = line.substr(line.find(',') + 1);
    fs::copy_file(src_dir + "/mav0/cam0/data/" + name, d / ("mav0/cam0/data/" + name));
    ++n;
  }
  WriteText(d / "mav0/cam0/data.csv", csv);
  const Trajectory body = ReadTumTrajectory(src_dir + "/groundtruth_body.txt");
  const Trajectory camf = ReadTumTrajectory(src_dir + "/groundtruth.txt");
  std::string gt = "#timestamp,p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []\n";
  for (const StampedPose& p : body) {
    char buf[256];
    const auto& q = p.T_wc.rotation();
    const auto& t = p.T_wc.translation();
    std::snprintf(buf, sizeof(buf), "%lld,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,0,0,0\n", static_cast<long long>(p.t),
                  t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z());
    gt += buf;
  }
  WriteText(d / "mav0/state_groundtruth_estimate0/data.csv", gt);
  for (const std::string& path : {d.str(), d / "mav0"}) {  // sequence folder or mav0 itself
    DatasetOptions o;
    o.kind = DatasetKind::kEuroc;
    o.path = path;
    auto src = OpenDataset(o);
    ASSERT_EQ(src->size(), 4u);
    ASSERT_EQ(src->ground_truth().size(), camf.size());
    for (size_t i = 0; i < camf.size(); ++i) {
      EXPECT_LT((src->ground_truth()[i].second.translation() - camf[i].T_wc.translation()).norm(), 2e-6);
      EXPECT_LT(RotationAngle(src->ground_truth()[i].second.rotation().inverse() * camf[i].T_wc.rotation()), 1e-5);
    }
    Frame f;
    ASSERT_TRUE(src->Next(&f));
    EXPECT_EQ(f.timestamp, 1403715273262142976LL);
    ASSERT_TRUE(f.T_wc_gt.has_value());
    EXPECT_LT((f.T_wc_gt->translation() - camf[0].T_wc.translation()).norm(), 2e-6);
  }
  // Broken sensor.yaml: the error names the file.
  WriteText(d / "mav0/cam0/sensor.yaml", "%YAML:1.0\nintrinsics: [1, 2, 3]\n");
  DatasetOptions o;
  o.kind = DatasetKind::kEuroc;
  o.path = d.str();
  EXPECT_NE(ErrorOf(o).find("sensor.yaml"), std::string::npos) << ErrorOf(o);
  fs::remove(d / "mav0/cam0/sensor.yaml");
  EXPECT_NE(ErrorOf(o).find("sensor.yaml"), std::string::npos) << ErrorOf(o);
  fs::remove_all(d / "mav0");
  EXPECT_NE(ErrorOf(o).find("mav0"), std::string::npos) << ErrorOf(o);
}

}  // namespace
}  // namespace rumi
