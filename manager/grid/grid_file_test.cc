#include "manager/grid/grid_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "common/atomic_file.h"
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;

class GridFile : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_.Create();
    for (int t = 0; t < 3; ++t)
      for (double y = -1; y <= 1; y += 0.02) grid_.AddRay({0, 0}, {2.0, y}, true);
  }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }
  static OccupancyGridOptions Cells5cm() {
    OccupancyGridOptions o;
    o.resolution_m = 0.05;
    return o;
  }
  TempDir tmp_;
  fs::path dir_ = tmp_.path();
  OccupancyGrid grid_{Cells5cm()};
};

TEST_F(GridFile, MapServerReadsWhatWasWritten) {
  std::string why;
  ASSERT_TRUE(WriteMapServerGrid(grid_, P("grid.pgm"), P("grid.yaml"), {"rumi_scale_source: odometry"}, &why))
      << why;
  MapServerGrid m;
  ASSERT_TRUE(ReadMapServerGrid(P("grid.yaml"), &m, &why)) << why;
  EXPECT_EQ(m.image, "grid.pgm");  // relative to the YAML, as map_server resolves it
  EXPECT_EQ(m.mode, "trinary");
  EXPECT_EQ(m.negate, 0);
  EXPECT_DOUBLE_EQ(m.occupied_thresh, 0.65);
  EXPECT_DOUBLE_EQ(m.free_thresh, 0.196);
  EXPECT_DOUBLE_EQ(m.resolution, grid_.resolution());
  EXPECT_NEAR(m.origin.x(), grid_.origin().x(), 1e-9);
  EXPECT_NEAR(m.origin.y(), grid_.origin().y(), 1e-9);
  EXPECT_EQ(m.origin.z(), 0.0);
  ASSERT_EQ(m.width, grid_.width());
  ASSERT_EQ(m.height, grid_.height());
  int counts[3] = {0, 0, 0};
  for (int r = 0; r < m.height; ++r)
    for (int c = 0; c < m.width; ++c) {
      ASSERT_EQ(m.State(c, r), grid_.State(c, r)) << c << " " << r;
      ++counts[static_cast<int>(m.State(c, r))];
    }
  EXPECT_GT(counts[static_cast<int>(CellState::kOccupied)], 30);
  EXPECT_GT(counts[static_cast<int>(CellState::kFree)], 300);
  // Only the three map_server values, and row 0 is the top (largest y): the
  // wall at x = 2 m, y in [-1, 1] is where map_server would draw it.
  for (uint8_t v : m.pixels) EXPECT_TRUE(v == kPgmFree || v == kPgmOccupied || v == kPgmUnknown) << int(v);
  const int col = static_cast<int>((2.01 - m.origin.x()) / m.resolution);
  const int top_row_of_y = m.height - 1 - static_cast<int>((0.9 - m.origin.y()) / m.resolution);
  EXPECT_EQ(m.pixels[static_cast<size_t>(top_row_of_y) * m.width + col], kPgmOccupied);
  // Another reader (OpenCV) agrees on the image.
  const cv::Mat img = cv::imread(P("grid.pgm"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(img.type(), CV_8UC1);
  EXPECT_EQ(img.cols, m.width);
  EXPECT_EQ(img.at<uint8_t>(top_row_of_y, col), kPgmOccupied);
  // rumi's own keys are there for rumi, ignored by map_server.
  std::ifstream in(P("grid.yaml"));
  std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find("rumi_scale_source: odometry"), std::string::npos);
}

TEST_F(GridFile, PreviewIsAPng) {
  std::string why;
  ASSERT_TRUE(WriteGridPreview(grid_, {{0, 0}, {0.5, 0.1}, {1.0, 0.0}}, P("grid.png"), &why)) << why;
  const cv::Mat img = cv::imread(P("grid.png"));
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, grid_.width());
  EXPECT_EQ(img.rows, grid_.height());
}

TEST_F(GridFile, BadFilesNameTheProblem) {
  std::string why;
  MapServerGrid m;
  EXPECT_FALSE(ReadMapServerGrid(P("missing.yaml"), &m, &why));
  EXPECT_NE(why.find("missing.yaml"), std::string::npos) << why;

  ASSERT_TRUE(WriteFileAtomically(P("a.yaml"), std::string("image: a.pgm\nresolution: 0.05\n"), &why));
  EXPECT_FALSE(ReadMapServerGrid(P("a.yaml"), &m, &why));
  EXPECT_NE(why.find("origin"), std::string::npos) << why;

  ASSERT_TRUE(WriteMapServerGrid(grid_, P("b.pgm"), P("b.yaml"), {}, &why)) << why;
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(ReadFileBytes(P("b.pgm"), &bytes, &why));
  bytes.resize(bytes.size() - 10);  // truncated
  ASSERT_TRUE(WriteFileAtomically(P("b.pgm"), bytes, &why));
  EXPECT_FALSE(ReadMapServerGrid(P("b.yaml"), &m, &why));
  EXPECT_NE(why.find("b.pgm"), std::string::npos) << why;

  bytes[1] = '2';  // ASCII PGM: not what rumi writes
  ASSERT_TRUE(WriteFileAtomically(P("b.pgm"), bytes, &why));
  EXPECT_FALSE(ReadMapServerGrid(P("b.yaml"), &m, &why));
  EXPECT_NE(why.find("P5"), std::string::npos) << why;

  EXPECT_FALSE(WriteMapServerGrid(OccupancyGrid(), P("c.pgm"), P("c.yaml"), {}, &why));
  EXPECT_NE(why.find("empty"), std::string::npos) << why;
}

}  // namespace
}  // namespace rumi
