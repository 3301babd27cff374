#include "back/colmap_workspace.h"

#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "back/model_to_submap.h"
#include "common/testing/temp_dir.h"

namespace fs = std::filesystem;

namespace rumi {
namespace {

constexpr Timestamp kT0 = 1000000000LL, kDt = 100000000LL;

ImageWindow Window(int n) {
  ImageWindow w;
  w.id = 3;
  w.camera.width = 64;
  w.camera.height = 48;
  w.camera.fx = w.camera.fy = 50;
  w.camera.cx = 31.5;
  w.camera.cy = 23.5;
  for (int i = 0; i < n; ++i) {
    WindowFrame f;
    f.timestamp = kT0 + kDt * i;
    f.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(100 + i));
    w.frames.push_back(f);
  }
  return w;
}

// Frames `blank` blank; a stretch over them when there are 3 or more.
WindowLayout Layout(const ImageWindow& w, const std::vector<int>& blank) {
  WindowLayout l;
  l.blank.assign(w.frames.size(), false);
  for (int i : blank) l.blank[i] = true, ++l.num_blank;
  l.side.assign(w.frames.size(), 0);
  if (blank.size() >= 3) {
    l.stretches.push_back({w.frames[blank.front()].timestamp, w.frames[blank.back()].timestamp});
    for (size_t i = 0; i < w.frames.size(); ++i) l.side[i] = int(i) > blank.back();
  }
  return l;
}

std::vector<std::string> Lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

TEST(ColmapWorkspace, CreatedOwnedAndRemovedUnlessKept) {
  TempDir root;
  fs::path dir;
  {
    ColmapWorkspace ws(root.str(), 3, 7);
    dir = ws.dir();
    EXPECT_EQ(dir.filename().string(), "window_3_" + std::to_string(getpid()) + "_7");
    EXPECT_EQ(ws.sparse("_retry", true), dir / "sparse_retry_all");
    EXPECT_FALSE(fs::exists(dir)) << "names only before Create";
    std::string why;
    ASSERT_TRUE(ws.Create(false, &why)) << why;
    EXPECT_TRUE(fs::is_directory(ws.images()));
    EXPECT_TRUE(fs::exists(dir / ".rumi-back-owner"));
    EXPECT_TRUE(ReclaimStaleWorkspaces(root.str()).empty()) << "its owner is alive";
  }
  EXPECT_FALSE(fs::exists(dir));
  {
    ColmapWorkspace ws(root.str(), 3, 8);
    std::string why;
    ASSERT_TRUE(ws.Create(true, &why)) << why;
    dir = ws.dir();
  }
  EXPECT_TRUE(fs::is_directory(dir / "images"));
  EXPECT_FALSE(fs::exists(dir / ".rumi-back-owner")) << "a kept workspace is released";
}

TEST(ColmapWorkspace, AWorkspaceThatCannotBeMadeIsSaid) {
  TempDir root;
  fs::create_directories(root.path());
  std::ofstream(root / "file") << "x";
  ColmapWorkspace ws(root / "file", 1, 0);
  std::string why;
  EXPECT_FALSE(ws.Create(false, &why));
  EXPECT_EQ(why.rfind("cannot create workspace " + ws.dir().string() + ": ", 0), 0u) << why;
  EXPECT_TRUE(fs::exists(root / "file"));
}

TEST(ColmapWorkspace, ImagesAreWrittenByTimestampBlankOnesLeftOut) {
  TempDir root;
  ImageWindow w = Window(4);
  ColmapWorkspace ws(root.str(), w.id, 0);
  std::string why;
  ASSERT_TRUE(ws.Create(false, &why)) << why;
  std::unordered_map<Timestamp, cv::Mat> written;
  ASSERT_TRUE(WriteColmapImages(w, {false, true, false, false}, false, ws, &written, &why)) << why;
  EXPECT_EQ(written.size(), 3u);
  EXPECT_FALSE(fs::exists(ws.images() / ColmapImageName(w.frames[1].timestamp)));
  const cv::Mat back = cv::imread((ws.images() / ColmapImageName(w.frames[2].timestamp)).string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(back.empty());
  EXPECT_EQ(cv::norm(back, w.frames[2].image, cv::NORM_INF), 0) << "no distortion, no stretch: as captured";
  // Stretched: a flat grey frame stays as it is (no spread to stretch), a low-contrast one spans 0..255.
  w.frames[0].image.colRange(0, 32).setTo(90);
  ASSERT_TRUE(WriteColmapImages(w, {false, true, false, false}, true, ws, &written, &why)) << why;
  double lo, hi;
  cv::minMaxLoc(written[w.frames[0].timestamp], &lo, &hi);
  EXPECT_EQ(lo, 0);
  EXPECT_EQ(hi, 255);
  EXPECT_EQ(cv::norm(written[w.frames[2].timestamp], w.frames[2].image, cv::NORM_INF), 0);
}

TEST(ColmapWorkspace, NoPairCrossesABlankStretch) {
  const ImageWindow w = Window(9);
  const WindowLayout l = Layout(w, {3, 4, 5});
  PairSelectionOptions po;
  const auto selected = SelectWindowPairs(w, l, po);
  EXPECT_EQ(selected, (std::vector<std::pair<int, int>>{{0, 1}, {0, 2}, {1, 2}, {6, 7}, {6, 8}, {7, 8}}));
  EXPECT_TRUE(FillPairs(l, selected).empty());
  po.overlap = 1;
  po.quadratic = false;
  const auto few = SelectWindowPairs(w, l, po);
  EXPECT_EQ(few, (std::vector<std::pair<int, int>>{{0, 1}, {1, 2}, {6, 7}, {7, 8}}));
  EXPECT_EQ(FillPairs(l, few), (std::vector<std::pair<int, int>>{{0, 2}, {6, 8}}));
}

TEST(ColmapWorkspace, PairListsAreWrittenForTheMatcher) {
  TempDir root;
  const ImageWindow w = Window(9);
  ColmapWorkspace ws(root.str(), w.id, 0);
  std::string why;
  ASSERT_TRUE(ws.Create(false, &why)) << why;
  PairSelectionOptions po;
  po.overlap = 1;
  po.quadratic = false;
  int matched = -1;
  ASSERT_TRUE(WritePairLists("pairs", w, Layout(w, {3, 4, 5}), po, ws, &matched, &why)) << why;
  EXPECT_EQ(matched, 4);
  const auto name = [&](int i) { return ColmapImageName(w.frames[i].timestamp); };
  EXPECT_EQ(Lines(ws.pairs()), (std::vector<std::string>{name(0) + " " + name(1), name(1) + " " + name(2),
                                                         name(6) + " " + name(7), name(7) + " " + name(8)}));
  EXPECT_EQ(Lines(ws.fill_pairs()), (std::vector<std::string>{name(0) + " " + name(2), name(6) + " " + name(8)}));
  // No stretch: no fill list (the fill matches every pair). Exhaustive: the pairs of the frames not blank.
  fs::remove(ws.fill_pairs());
  ASSERT_TRUE(WritePairLists("pairs", w, Layout(w, {}), po, ws, &matched, &why)) << why;
  EXPECT_FALSE(fs::exists(ws.fill_pairs()));
  ASSERT_TRUE(WritePairLists("exhaustive", w, Layout(w, {0}), po, ws, &matched, &why)) << why;
  EXPECT_EQ(matched, 28);
  matched = 0;
  ASSERT_TRUE(WritePairLists("sequential", w, Layout(w, {}), po, ws, &matched, &why)) << why;
  EXPECT_EQ(matched, 0);
  fs::remove_all(ws.dir());
  EXPECT_FALSE(WritePairLists("pairs", w, Layout(w, {}), po, ws, &matched, &why));
  EXPECT_EQ(why, "cannot write " + ws.pairs().string());
}

}  // namespace
}  // namespace rumi
