#include "ipc/link/link_frame_image.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "rumi_link.h"

namespace rumi {
namespace {

cv::Mat Pattern() {
  cv::Mat m(24, 32, CV_8UC1);
  for (int v = 0; v < m.rows; ++v)
    for (int u = 0; u < m.cols; ++u) m.at<uint8_t>(v, u) = static_cast<uint8_t>(((u / 4 + v / 4) & 1) ? 200 : 40);
  return m;
}

TEST(LinkFrameImage, DecodesJpegAndGrey) {
  const cv::Mat img = Pattern();
  LinkFrame f;
  f.width = 32, f.height = 24;
  f.format = RL_FORMAT_JPEG;
  ASSERT_TRUE(cv::imencode(".jpg", img, f.data, {cv::IMWRITE_JPEG_QUALITY, 95}));
  cv::Mat g = DecodeLinkFrame(f);
  ASSERT_EQ(g.type(), CV_8UC1);
  ASSERT_EQ(g.size(), img.size());
  EXPECT_LT(cv::norm(g, img, cv::NORM_INF), 40);
  f.format = RL_FORMAT_GREY;
  f.data.assign(img.data, img.data + img.total());
  g = DecodeLinkFrame(f);
  ASSERT_FALSE(g.empty());
  EXPECT_EQ(cv::norm(g, img, cv::NORM_INF), 0);
  f.data.clear();  // the decoded image owns its pixels
  EXPECT_EQ(cv::norm(g, img, cv::NORM_INF), 0);
}

TEST(LinkFrameImage, GarbageAndMismatchesAreEmpty) {
  LinkFrame f;
  f.width = 32, f.height = 24;
  f.format = RL_FORMAT_JPEG;
  f.data = {0xff, 0xd8, 0x00, 0x11, 0x22};
  EXPECT_TRUE(DecodeLinkFrame(f).empty());
  f.format = RL_FORMAT_GREY;
  f.data.assign(32 * 24 - 1, 7);
  EXPECT_TRUE(DecodeLinkFrame(f).empty());
  f.format = 99;
  f.data.assign(32 * 24, 7);
  EXPECT_TRUE(DecodeLinkFrame(f).empty());
}

}  // namespace
}  // namespace rumi
