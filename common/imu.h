#pragma once
// IMU samples, their file (EuRoC's imu0/data.csv columns, which `rumi synth`
// writes too) and the gyro integration that gives the body's rotation
// between two frames: the front's rotation prior when a robot has an IMU.
#include <cstddef>
#include <deque>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/timestamp.h"

namespace rumi {

struct ImuSample {
  Timestamp t = 0;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, body frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s^2, body frame (specific force)
};

// EuRoC imu0 layout: "timestamp [ns], w_x, w_y, w_z, a_x, a_y, a_z"; '#'
// lines are comments. Throws naming the file and line on a malformed row or
// samples out of time order.
std::vector<ImuSample> ReadImuCsv(const std::string& path);
std::string FormatImuCsv(const std::vector<ImuSample>& samples, const std::string& comment = "");

// A recorded IMU file handed out as a robot would deliver it: every sample up
// to a frame's time and the next one (so the frame's end is covered). A
// looped dataset shifts the samples with its frames (offset).
class ImuReplay {
 public:
  explicit ImuReplay(std::vector<ImuSample> samples) : samples_(std::move(samples)) {}
  std::vector<ImuSample> Until(Timestamp t, Timestamp offset = 0);
  bool empty() const { return samples_.empty(); }
  size_t size() const { return samples_.size(); }

 private:
  std::vector<ImuSample> samples_;
  size_t next_ = 0;
  Timestamp offset_ = 0;
};

struct GyroIntegratorOptions {
  size_t max_samples = 4000;   // older samples are dropped (20 s at 200 Hz)
  // A span is integrated only when samples lie this close to both its ends
  // and no gap inside is longer (a link that lost IMU batches gives no prior).
  double max_gap_s = 0.05;
};

// Buffers gyro samples (time order) and integrates the bias-corrected rate
// over [t0, t1], the rate linear between samples.
class GyroIntegrator {
 public:
  explicit GyroIntegrator(const GyroIntegratorOptions& o = {}) : o_(o) {}
  // Appends a sample; one not after the newest is ignored.
  void Add(Timestamp t, const Eigen::Vector3d& gyro);
  // R_b0_b1: the body at t1 in the body at t0; nullopt when the samples do
  // not cover the span (see max_gap_s) or t1 < t0.
  std::optional<Eigen::Quaterniond> Rotation(Timestamp t0, Timestamp t1,
                                             const Eigen::Vector3d& bias = Eigen::Vector3d::Zero()) const;
  bool empty() const { return samples_.empty(); }
  size_t size() const { return samples_.size(); }

 private:
  Eigen::Vector3d RateAt(size_t i, Timestamp t) const;  // between samples i and i + 1

  GyroIntegratorOptions o_;
  std::deque<std::pair<Timestamp, Eigen::Vector3d>> samples_;
};

}  // namespace rumi
