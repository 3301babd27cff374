#pragma once
// PnP RANSAC from a pose guess, as the manager's loop verification and
// revisit placement run it on undistorted keypoints.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

#include "common/geometry.h"
#include "common/submap.h"

namespace rumi {

// OpenCV's iterative PnP RANSAC (100 iterations, confidence 0.99) of 3D points
// and their undistorted keypoints (the pinhole K, no distortion), started at
// the guess (R0, t0: world -> camera). The pose found (world -> camera) and
// the inliers' indices; false when OpenCV found none.
bool PnpRansacFromGuess(const std::vector<cv::Point3f>& points, const std::vector<cv::Point2f>& keypoints,
                        const CameraIntrinsics& K, const Eigen::Matrix3d& R0, const Eigen::Vector3d& t0,
                        double threshold_px, Se3* T_cw, std::vector<int>* inliers);

}  // namespace rumi
