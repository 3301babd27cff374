#include "front/feature_extractor.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

namespace rumi {

FeatureExtractor::FeatureExtractor(const OrbExtractorOptions& orb, const PinholeCamera& camera)
    : orb_(orb), camera_(camera), pyramid_(orb.num_levels, orb.scale_factor) {
  const double w = camera.width(), h = camera.height();
  min_x_ = 0; min_y_ = 0; max_x_ = w; max_y_ = h;
  if (camera.HasDistortion()) {  // the corners bound the undistorted image
    const auto c = camera.UndistortPoints({{0, 0}, {w, 0}, {0, h}, {w, h}});
    min_x_ = std::min(c[0].x(), c[2].x()); max_x_ = std::max(c[1].x(), c[3].x());
    min_y_ = std::min(c[0].y(), c[1].y()); max_y_ = std::max(c[2].y(), c[3].y());
  }
}

std::shared_ptr<Features> FeatureExtractor::Extract(const cv::Mat& image) {
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4) cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  if (grey.depth() != CV_8U) grey.convertTo(grey, CV_8U);
  auto f = std::make_shared<Features>();
  f->width = grey.cols;
  f->height = grey.rows;
  orb_.Extract(grey, &f->keypoints, &f->descriptors);
  f->un.resize(f->keypoints.size());
  for (size_t i = 0; i < f->keypoints.size(); ++i)
    f->un[i] = camera_.UndistortPoint({f->keypoints[i].pt.x, f->keypoints[i].pt.y});
  f->min_x = min_x_; f->min_y = min_y_; f->max_x = max_x_; f->max_y = max_y_;
  f->BuildGrid(std::max(1, static_cast<int>((max_x_ - min_x_) / 10)), std::max(1, static_cast<int>((max_y_ - min_y_) / 10)));
  return f;
}

}  // namespace rumi
