#pragma once
// ORB features of one image, undistorted once with the camera's model: every
// other part of the front then works on undistorted pixels with the pinhole K
// alone (front/map.h ProjectUndistorted).
#include <memory>

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/orb_extractor.h"
#include "front/map.h"

namespace rumi {

class FeatureExtractor {
 public:
  FeatureExtractor(const OrbExtractorOptions& orb, const PinholeCamera& camera);
  // An 8-bit grey, BGR or BGRA image (other depths are converted).
  std::shared_ptr<Features> Extract(const cv::Mat& image);
  const ScalePyramid& pyramid() const { return pyramid_; }

 private:
  OrbExtractor orb_;
  PinholeCamera camera_;
  ScalePyramid pyramid_;
  double min_x_ = 0, min_y_ = 0, max_x_ = 0, max_y_ = 0;  // the undistorted image's bounds
};

}  // namespace rumi
