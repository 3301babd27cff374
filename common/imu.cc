#include "common/imu.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "common/dataset_util.h"

namespace rumi {

std::vector<ImuSample> ReadImuCsv(const std::string& path) {
  RequireFile(path, "IMU file");
  std::ifstream in(path);
  std::vector<ImuSample> out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> f = SplitFields(line, true);
    if (f.size() < 7) ThrowAtLine(path, n, "expected 7 columns (timestamp [ns], w_x w_y w_z, a_x a_y a_z)");
    ImuSample s;
    try {
      size_t used = 0;
      s.t = std::stoll(f[0], &used);
      if (used != f[0].size()) throw std::invalid_argument(f[0]);
      for (int k = 0; k < 3; ++k) {
        s.gyro[k] = std::stod(f[1 + k], &used);
        if (used != f[1 + k].size()) throw std::invalid_argument(f[1 + k]);
        s.accel[k] = std::stod(f[4 + k], &used);
        if (used != f[4 + k].size()) throw std::invalid_argument(f[4 + k]);
      }
    } catch (const std::logic_error&) {
      ThrowAtLine(path, n, "not a number in '" + line + "'");
    }
    if (!s.gyro.allFinite() || !s.accel.allFinite()) ThrowAtLine(path, n, "a value is not finite");
    if (!out.empty() && s.t <= out.back().t) ThrowAtLine(path, n, "timestamps must increase");
    out.push_back(s);
  }
  if (out.empty()) throw std::runtime_error(path + ": no IMU samples");
  return out;
}

std::string FormatImuCsv(const std::vector<ImuSample>& samples, const std::string& comment) {
  std::ostringstream o;
  o.precision(9);
  if (!comment.empty()) o << "# " << comment << '\n';
  o << "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
       "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
  for (const ImuSample& s : samples)
    o << s.t << ',' << s.gyro.x() << ',' << s.gyro.y() << ',' << s.gyro.z() << ',' << s.accel.x() << ','
      << s.accel.y() << ',' << s.accel.z() << '\n';
  return o.str();
}

std::vector<ImuSample> ImuReplay::Until(Timestamp t, Timestamp offset) {
  if (offset != offset_) {
    offset_ = offset;
    next_ = 0;
  }
  std::vector<ImuSample> out;
  while (next_ < samples_.size() && (next_ == 0 || samples_[next_ - 1].t + offset_ <= t)) {
    ImuSample s = samples_[next_++];
    s.t += offset_;
    out.push_back(s);
  }
  return out;
}

void GyroIntegrator::Add(Timestamp t, const Eigen::Vector3d& gyro) {
  if (!samples_.empty() && t <= samples_.back().first) return;
  if (!gyro.allFinite()) return;
  samples_.push_back({t, gyro});
  while (o_.max_samples > 0 && samples_.size() > o_.max_samples) samples_.pop_front();
}

Eigen::Vector3d GyroIntegrator::RateAt(size_t i, Timestamp t) const {
  const auto& [ta, wa] = samples_[i];
  const auto& [tb, wb] = samples_[i + 1];
  const double a = static_cast<double>(t - ta) / static_cast<double>(tb - ta);
  return (1 - a) * wa + a * wb;
}

std::optional<Eigen::Quaterniond> GyroIntegrator::Rotation(Timestamp t0, Timestamp t1,
                                                           const Eigen::Vector3d& bias) const {
  if (t1 < t0 || samples_.size() < 2) return std::nullopt;
  const Timestamp max_gap = SecondsToNs(o_.max_gap_s);
  // Samples must reach both ends (within one gap) ...
  if (samples_.front().first > t0 + max_gap / 2 || samples_.back().first < t1 - max_gap / 2) return std::nullopt;
  size_t i = 0;  // the segment [i, i + 1] holding t0 (clamped to the samples)
  while (i + 2 < samples_.size() && samples_[i + 1].first <= t0) ++i;
  Eigen::Quaterniond R = Eigen::Quaterniond::Identity();
  Timestamp t = t0;
  auto clamp_rate = [&](size_t k, Timestamp at) {
    return RateAt(k, std::clamp(at, samples_[k].first, samples_[k + 1].first));
  };
  while (t < t1) {
    // ... and none inside may be missing.
    if (samples_[i + 1].first - samples_[i].first > max_gap && samples_[i + 1].first > t0 &&
        samples_[i].first < t1)
      return std::nullopt;
    const Timestamp end = (i + 2 < samples_.size()) ? std::min(t1, std::max(t, samples_[i + 1].first)) : t1;
    if (end > t) {
      // Midpoint rule on the linear rate: exact for a constant axis.
      const Eigen::Vector3d w = clamp_rate(i, t + (end - t) / 2) - bias;
      const Eigen::Vector3d phi = w * NsToSeconds(end - t);
      const double angle = phi.norm();
      if (angle > 1e-12) R = R * Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle));
      t = end;
    }
    if (t < t1) ++i;
  }
  return R.normalized();
}

}  // namespace rumi
