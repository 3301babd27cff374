#include "common/trajectory.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "common/atomic_file.h"
#include "common/text_fields.h"

namespace rumi {
namespace {

// A quaternion whose norm is this far from 1 is a broken file, not rounding
// (TUM ground truth with 4 decimals is off by ~1e-4).
constexpr double kUnitTolerance = 1e-2;

[[noreturn]] void Fail(const std::string& name, int line, const std::string& why) {
  throw std::runtime_error(name + ":" + std::to_string(line) + ": " + why);
}

std::vector<std::string> SplitComma(const std::string& s) {
  std::vector<std::string> out;
  size_t start = 0;
  while (true) {
    const size_t c = s.find(',', start);
    out.push_back(Trim(s.substr(start, c == std::string::npos ? std::string::npos : c - start)));
    if (c == std::string::npos) break;
    start = c + 1;
  }
  return out;
}

// Parses tokens[first, first+count) as doubles, naming the bad column.
void ParseNumbers(const std::vector<std::string>& tokens, size_t first, size_t count,
                  const std::string& name, int line, double* out) {
  for (size_t i = 0; i < count; ++i) {
    if (!ParseFiniteDouble(tokens[first + i], &out[i])) {
      Fail(name, line, "column " + std::to_string(first + i + 1) + " '" + tokens[first + i] +
                           "' is not a finite number");
    }
  }
}

Se3 PoseFromQuaternion(const Eigen::Vector3d& t, double qw, double qx, double qy, double qz,
                       const std::string& name, int line) {
  const double norm = std::sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
  if (std::abs(norm - 1.0) > kUnitTolerance) {
    Fail(name, line, "quaternion norm " + std::to_string(norm) + " is not 1");
  }
  return Se3(Eigen::Quaterniond(qw, qx, qy, qz), t);
}

// Tracks the previous timestamp so that unsorted or duplicate lines fail at
// the line where they occur. Add() returns false for a duplicate to drop.
class OrderCheck {
 public:
  explicit OrderCheck(const std::string& name, bool drop_duplicates = false)
      : name_(name), drop_duplicates_(drop_duplicates) {}
  ~OrderCheck() {
    if (dropped_ > 0) {
      spdlog::warn("{}: dropped {} pose(s) with duplicate timestamps (first on line {})", name_,
                   dropped_, first_dropped_line_);
    }
  }
  bool Add(Timestamp t, int line) {
    if (has_prev_ && t == prev_ && drop_duplicates_) {
      if (dropped_++ == 0) first_dropped_line_ = line;
      return false;
    }
    if (has_prev_ && t <= prev_) {
      Fail(name_, line,
           "timestamp " + FormatSeconds(t) + (t == prev_ ? " duplicates" : " is before") +
               " the one on line " + std::to_string(prev_line_) + " (" + FormatSeconds(prev_) +
               "); timestamps must be strictly increasing");
    }
    has_prev_ = true;
    prev_ = t;
    prev_line_ = line;
    return true;
  }

 private:
  const std::string& name_;
  bool drop_duplicates_;
  bool has_prev_ = false;
  Timestamp prev_ = 0;
  int prev_line_ = 0;
  int dropped_ = 0;
  int first_dropped_line_ = 0;
};

// A trajectory of hours at hundreds of Hz is tens of MB: 1 GiB is no trajectory.
constexpr uint64_t kMaxTrajectoryBytes = uint64_t(1) << 30;

std::ifstream OpenForRead(const std::string& path, const char* what) {
  std::string why;
  if (!CheckRegularFile(path, kMaxTrajectoryBytes, &why))
    throw std::runtime_error(std::string("cannot read ") + what + ": " + why);
  std::ifstream in(path);
  if (!in) throw std::runtime_error(std::string("cannot open ") + what + " '" + path + "'");
  return in;
}

// Atomically (common/atomic_file.h): a reader never sees half a trajectory.
template <typename Format>
void WriteFile(const std::string& path, const Trajectory& traj, Format format) {
  std::ostringstream out;
  format(traj, out);
  std::string why;
  if (!WriteFileAtomically(path, out.str(), &why)) throw std::runtime_error(why);
}

}  // namespace

bool ParseTrajectoryFormat(const std::string& name, TrajectoryFormat* format) {
  if (name == "tum") {
    *format = TrajectoryFormat::kTum;
  } else if (name == "kitti") {
    *format = TrajectoryFormat::kKitti;
  } else if (name == "euroc") {
    *format = TrajectoryFormat::kEuroc;
  } else {
    return false;
  }
  return true;
}

const char* ToString(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum:
      return "tum";
    case TrajectoryFormat::kKitti:
      return "kitti";
    case TrajectoryFormat::kEuroc:
      return "euroc";
  }
  return "?";
}

TrajectoryFormat DetectTrajectoryFormat(const std::string& path) {
  std::ifstream in = OpenForRead(path, "trajectory");
  bool found = false;
  TrajectoryFormat format = TrajectoryFormat::kTum;
  ForEachDataLine(in, [&](int line, const std::string& s) {  // the first data line tells
    found = true;
    if (s.find(',') != std::string::npos) {
      format = TrajectoryFormat::kEuroc;
      return false;
    }
    const size_t n = SplitFields(s, false).size();
    if (n == 12) format = TrajectoryFormat::kKitti;
    else if (n == 8) format = TrajectoryFormat::kTum;
    else
      Fail(path, line,
           "cannot tell the trajectory format from " + std::to_string(n) +
               " fields (TUM has 8, KITTI 12, EuRoC is comma-separated); give it explicitly");
    return false;
  });
  if (!found) throw std::runtime_error("trajectory '" + path + "' has no data lines");
  return format;
}

Trajectory ParseTumTrajectory(std::istream& in, const std::string& name,
                              const TrajectoryReadOptions& options) {
  Trajectory traj;
  OrderCheck order(name, options.drop_duplicates);
  ForEachDataLine(in, [&](int line, const std::string& s) {
    const std::vector<std::string> tok = SplitFields(s, false);
    if (tok.size() != 8) {
      Fail(name, line,
           "expected 8 fields 't tx ty tz qx qy qz qw', got " + std::to_string(tok.size()));
    }
    StampedPose p;
    if (!ParseSecondsToNs(tok[0], &p.t)) Fail(name, line, "bad timestamp '" + tok[0] + "'");
    double v[7];
    ParseNumbers(tok, 1, 7, name, line, v);
    p.T_wc = PoseFromQuaternion(Eigen::Vector3d(v[0], v[1], v[2]), v[6], v[3], v[4], v[5], name,
                                line);
    if (order.Add(p.t, line)) traj.push_back(p);
    return true;
  });
  return traj;
}

Trajectory ParseKittiTrajectory(std::istream& in, const std::string& name) {
  Trajectory traj;
  ForEachDataLine(in, [&](int line, const std::string& s) {
    const std::vector<std::string> tok = SplitFields(s, false);
    if (tok.size() != 12) {
      Fail(name, line,
           "expected 12 fields (3x4 row-major [R|t]), got " + std::to_string(tok.size()));
    }
    double v[12];
    ParseNumbers(tok, 0, 12, name, line, v);
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) R(r, c) = v[4 * r + c];
      t(r) = v[4 * r + 3];
    }
    const double ortho = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
    if (ortho > kUnitTolerance || R.determinant() <= 0.0) {
      Fail(name, line, "the 3x3 block is not a rotation (|R^T R - I| = " + std::to_string(ortho) +
                           ", det = " + std::to_string(R.determinant()) + ")");
    }
    // Files store rounded matrices: use the nearest rotation.
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
    StampedPose p;
    p.t = static_cast<Timestamp>(traj.size()) * kNsPerSecond;
    p.T_wc = Se3(Eigen::Matrix3d(svd.matrixU() * svd.matrixV().transpose()), t);
    traj.push_back(p);
    return true;
  });
  return traj;
}

Trajectory ParseEurocTrajectory(std::istream& in, const std::string& name,
                                const TrajectoryReadOptions& options) {
  Trajectory traj;
  OrderCheck order(name, options.drop_duplicates);
  ForEachDataLine(in, [&](int line, const std::string& s) {
    const std::vector<std::string> tok = SplitComma(s);
    if (tok.size() < 8) {
      Fail(name, line,
           "expected at least 8 comma-separated fields 'timestamp_ns,px,py,pz,qw,qx,qy,qz', got " +
               std::to_string(tok.size()));
    }
    StampedPose p;
    if (!ParseInt64(tok[0], &p.t)) {
      Fail(name, line, "timestamp '" + tok[0] + "' is not an integer number of nanoseconds");
    }
    double v[7];
    ParseNumbers(tok, 1, 7, name, line, v);
    p.T_wc = PoseFromQuaternion(Eigen::Vector3d(v[0], v[1], v[2]), v[3], v[4], v[5], v[6], name,
                                line);
    if (order.Add(p.t, line)) traj.push_back(p);
    return true;
  });
  return traj;
}

std::vector<Timestamp> ParseTimestampList(std::istream& in, const std::string& name) {
  std::vector<Timestamp> out;
  OrderCheck order(name);
  ForEachDataLine(in, [&](int line, const std::string& s) {
    // First column only, so TUM rgb.txt / trajectory files work as lists too.
    const std::string tok = SplitFields(s, false)[0];
    Timestamp t = 0;
    if (!ParseSecondsToNs(tok, &t)) Fail(name, line, "bad timestamp '" + tok + "'");
    order.Add(t, line);
    out.push_back(t);
    return true;
  });
  return out;
}

void FormatTumTrajectory(const Trajectory& traj, std::ostream& out) {
  out << "# timestamp tx ty tz qx qy qz qw\n";
  char buf[256];
  for (const StampedPose& p : traj) {
    const Eigen::Vector3d& t = p.T_wc.translation();
    const Eigen::Quaterniond& q = p.T_wc.rotation();
    std::snprintf(buf, sizeof(buf), " %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", t.x(), t.y(), t.z(),
                  q.x(), q.y(), q.z(), q.w());
    out << FormatSeconds(p.t) << buf;
  }
}

void FormatKittiTrajectory(const Trajectory& traj, std::ostream& out) {
  char buf[64];
  for (const StampedPose& p : traj) {
    const Eigen::Matrix<double, 3, 4> m = p.T_wc.Matrix3x4();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) {
        std::snprintf(buf, sizeof(buf), "%.17g", m(r, c));
        out << buf << (r == 2 && c == 3 ? '\n' : ' ');
      }
    }
  }
}

void FormatEurocTrajectory(const Trajectory& traj, std::ostream& out) {
  out << "#timestamp [ns],p_x [m],p_y [m],p_z [m],q_w [],q_x [],q_y [],q_z []\n";
  char buf[256];
  for (const StampedPose& p : traj) {
    const Eigen::Vector3d& t = p.T_wc.translation();
    const Eigen::Quaterniond& q = p.T_wc.rotation();
    std::snprintf(buf, sizeof(buf), "%" PRId64 ",%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n", p.t, t.x(),
                  t.y(), t.z(), q.w(), q.x(), q.y(), q.z());
    out << buf;
  }
}

Trajectory ReadTumTrajectory(const std::string& path, const TrajectoryReadOptions& options) {
  std::ifstream in = OpenForRead(path, "TUM trajectory");
  return ParseTumTrajectory(in, path, options);
}

Trajectory ReadKittiTrajectory(const std::string& path, const std::string& times_path) {
  std::ifstream in = OpenForRead(path, "KITTI trajectory");
  Trajectory traj = ParseKittiTrajectory(in, path);
  if (!times_path.empty()) {
    const std::vector<Timestamp> times = ReadTimestampList(times_path);
    if (times.size() != traj.size()) {
      throw std::runtime_error("KITTI times file '" + times_path + "' has " +
                               std::to_string(times.size()) + " timestamps but '" + path +
                               "' has " + std::to_string(traj.size()) + " poses");
    }
    for (size_t i = 0; i < traj.size(); ++i) traj[i].t = times[i];
  }
  return traj;
}

Trajectory ReadEurocTrajectory(const std::string& path, const TrajectoryReadOptions& options) {
  std::ifstream in = OpenForRead(path, "EuRoC trajectory");
  return ParseEurocTrajectory(in, path, options);
}

std::vector<Timestamp> ReadTimestampList(const std::string& path) {
  std::ifstream in = OpenForRead(path, "timestamp list");
  return ParseTimestampList(in, path);
}

Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format,
                          const std::string& kitti_times_path,
                          const TrajectoryReadOptions& options) {
  switch (format) {
    case TrajectoryFormat::kTum:
      return ReadTumTrajectory(path, options);
    case TrajectoryFormat::kKitti:
      return ReadKittiTrajectory(path, kitti_times_path);
    case TrajectoryFormat::kEuroc:
      return ReadEurocTrajectory(path, options);
  }
  throw std::runtime_error("unknown trajectory format");
}

void WriteTumTrajectory(const std::string& path, const Trajectory& traj) {
  WriteFile(path, traj, FormatTumTrajectory);
}

void WriteKittiTrajectory(const std::string& path, const Trajectory& traj) {
  WriteFile(path, traj, FormatKittiTrajectory);
}

void WriteEurocTrajectory(const std::string& path, const Trajectory& traj) {
  WriteFile(path, traj, FormatEurocTrajectory);
}

void WriteTrajectory(const std::string& path, const Trajectory& traj, TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum:
      return WriteTumTrajectory(path, traj);
    case TrajectoryFormat::kKitti:
      return WriteKittiTrajectory(path, traj);
    case TrajectoryFormat::kEuroc:
      return WriteEurocTrajectory(path, traj);
  }
}

void CheckStrictlyIncreasing(const Trajectory& traj, const std::string& name) {
  for (size_t i = 1; i < traj.size(); ++i) {
    if (traj[i].t <= traj[i - 1].t) {
      throw std::runtime_error(name + ": pose " + std::to_string(i) + " (t=" +
                               FormatSeconds(traj[i].t) + ") is not after pose " +
                               std::to_string(i - 1) + " (t=" + FormatSeconds(traj[i - 1].t) +
                               "); timestamps must be strictly increasing");
    }
  }
}

void SortOnePosePerTime(Trajectory* traj) {
  std::stable_sort(traj->begin(), traj->end(), [](const StampedPose& a, const StampedPose& b) { return a.t < b.t; });
  traj->erase(std::unique(traj->begin(), traj->end(),
                          [](const StampedPose& a, const StampedPose& b) { return a.t == b.t; }),
              traj->end());
}

}  // namespace rumi
