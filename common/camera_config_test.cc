#include "common/camera_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "common/dataset_util.h"

namespace rumi {
namespace {

const std::string kConfigs = std::string(RUMI_SOURCE_DIR) + "/configs";

TEST(CameraConfig, ReadsAllKeys) {
  ConfigSection root = LoadConfigString(
      "camera: {width: 752, height: 480, fx: 458.654, fy: -457.296, cx: 367.215, cy: 248.375,\n"
      "         k1: -0.28, k2: 0.07, p1: 0.0002, p2: 1.8e-05, k3: 0.01, flipped_y: true}\n",
      "c.yaml");
  ConfigSection cam = root.Child("camera");
  PinholeCameraOptions o;
  ReadOptions(cam, &o);
  EXPECT_EQ(o.width, 752);
  EXPECT_EQ(o.height, 480);
  EXPECT_EQ(o.fx, 458.654);
  EXPECT_EQ(o.fy, -457.296);
  EXPECT_EQ(o.cx, 367.215);
  EXPECT_EQ(o.cy, 248.375);
  EXPECT_EQ(o.k1, -0.28);
  EXPECT_EQ(o.k2, 0.07);
  EXPECT_EQ(o.p1, 0.0002);
  EXPECT_EQ(o.p2, 1.8e-05);
  EXPECT_EQ(o.k3, 0.01);
  EXPECT_NO_THROW(root.Finish());
}

TEST(CameraConfig, Errors) {
  auto error = [](const std::string& yaml) -> std::string {
    try {
      ConfigSection root = LoadConfigString(yaml, "cam.yaml");
      ConfigSection cam = root.Child("camera");
      PinholeCameraOptions o;
      ReadOptions(cam, &o);
      root.Finish();
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  std::string e = error("camera: {fx: 0}\n");
  EXPECT_NE(e.find("cam.yaml"), std::string::npos) << e;
  EXPECT_NE(e.find("focal"), std::string::npos) << e;
  e = error("camera: {width: 0}\n");
  EXPECT_NE(e.find("camera.width"), std::string::npos) << e;
  e = error("camera: {fx: abc}\n");
  EXPECT_NE(e.find("camera.fx"), std::string::npos) << e;
  e = error("camera: {fx: 500, k4: 0.1}\n");
  EXPECT_NE(e.find("camera.k4"), std::string::npos) << e;
  e = error("camera: {cx: .nan}\n");
  EXPECT_NE(e.find("camera.cx"), std::string::npos) << e;
  // Reported by a new user: both were accepted, and cx -5000 made the ATE 9x worse.
  e = error("camera: {fx: -262.5}\n");
  EXPECT_NE(e.find("focal lengths must be positive"), std::string::npos) << e;
  e = error("camera: {cx: -5000}\n");
  EXPECT_NE(e.find("principal point"), std::string::npos) << e;
  e = error("camera: {width: 320, height: 240, cx: 319.5, cy: 239.5, fx: 262.5, fy: 262.5}\n");
  EXPECT_EQ(e, "");  // inside
  e = error("camera: {width: 320, height: 240, cx: 639.5}\n");
  EXPECT_NE(e.find("outside the 320x240 image"), std::string::npos) << e;
  e = error("camera: {fy: -480}\n");
  EXPECT_NE(e.find("flipped_y: true"), std::string::npos) << e;
  e = error("camera: {fy: 480, flipped_y: true}\n");
  EXPECT_NE(e.find("fy must be negative"), std::string::npos) << e;
  EXPECT_EQ(error("camera: {fy: -480, flipped_y: true}\n"), "");
  EXPECT_EQ(error("camera: {fx: 500}\n"), "");
}

TEST(CameraConfig, SectionYamlReadsBack) {
  PinholeCameraOptions c;
  c.width = 752, c.height = 480;
  c.fx = 458.654321987654, c.fy = -457.296, c.cx = 367.215, c.cy = 248.375;
  c.k1 = -0.283408, c.k2 = 0.0739591, c.p1 = 0.00019359;
  c.p2 = 1.76187e-05, c.k3 = -1e-9;
  c.flipped_y = true;
  ConfigSection root = LoadConfigString(CameraSectionYaml(c), "c.yaml");
  ConfigSection cam = root.Child("camera");
  PinholeCameraOptions o;
  ReadOptions(cam, &o);
  EXPECT_NO_THROW(root.Finish());
  EXPECT_EQ(o.width, 752);
  EXPECT_EQ(o.height, 480);
  EXPECT_TRUE(o.flipped_y);
  for (auto [a, b] : {std::pair{o.fx, c.fx}, {o.fy, c.fy}, {o.cx, c.cx}, {o.cy, c.cy}, {o.k1, c.k1}, {o.k2, c.k2},
                      {o.p1, c.p1}, {o.p2, c.p2}, {o.k3, c.k3}}) {
    EXPECT_NEAR(a, b, 1e-11 * std::max(1e-6, std::abs(b)));
  }
}

// Every shipped config's camera section is complete (no silent defaults) and
// valid. (apps/config/rumi_config_test.cc loads the whole files.)
TEST(CameraConfig, EveryShippedConfigHasACompleteCamera) {
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kConfigs)) {
    if (entry.path().extension() != ".yaml") continue;
    const std::string path = entry.path().string();
    SCOPED_TRACE(path);
    ConfigSection root = LoadConfigFile(path);
    ASSERT_TRUE(root.Has("camera"));
    ConfigSection cam = root.Child("camera");
    PinholeCameraOptions o;
    ReadOptions(cam, &o);
    for (const char* key : {"width", "height", "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"}) {
      EXPECT_TRUE(cam.Has(key)) << key;
    }
    ++n;
  }
  EXPECT_GE(n, 8);
}

TEST(CameraConfig, TumConfigsMatchBuiltInCalibrations) {
  for (int fr = 1; fr <= 3; ++fr) {
    ConfigSection root = LoadConfigFile(kConfigs + "/tum_fr" + std::to_string(fr) + ".yaml");
    ConfigSection cam = root.Child("camera");
    PinholeCameraOptions o;
    ReadOptions(cam, &o);
    const PinholeCameraOptions b = TumCameraOptions(fr);
    EXPECT_EQ(o.width, b.width);
    EXPECT_EQ(o.height, b.height);
    EXPECT_EQ(o.fx, b.fx);
    EXPECT_EQ(o.fy, b.fy);
    EXPECT_EQ(o.cx, b.cx);
    EXPECT_EQ(o.cy, b.cy);
    EXPECT_EQ(o.k1, b.k1);
    EXPECT_EQ(o.k2, b.k2);
    EXPECT_EQ(o.p1, b.p1);
    EXPECT_EQ(o.p2, b.p2);
    EXPECT_EQ(o.k3, b.k3);
  }
  // ICL-NUIM and KITTI configs hold the published values.
  PinholeCameraOptions icl, kitti;
  ConfigSection ri = LoadConfigFile(kConfigs + "/icl_nuim.yaml");
  ConfigSection ci = ri.Child("camera");
  ReadOptions(ci, &icl);
  EXPECT_EQ(icl.fy, IclCameraOptions().fy);
  EXPECT_EQ(icl.fx, IclCameraOptions().fx);
  ConfigSection rk = LoadConfigFile(kConfigs + "/kitti.yaml");
  ConfigSection ck = rk.Child("camera");
  ReadOptions(ck, &kitti);
  EXPECT_EQ(kitti.width, 1242);
  EXPECT_EQ(kitti.height, 375);
  EXPECT_EQ(kitti.fx, 721.5377);
  EXPECT_EQ(kitti.cy, 172.854);
}

}  // namespace
}  // namespace rumi
