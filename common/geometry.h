#pragma once
// Rigid and similarity transforms on Eigen. Naming convention used across
// rumi: T_ab maps points expressed in frame b into frame a (p_a = T_ab * p_b).
// T_cw: world -> camera (optimisation); T_wc: camera -> world (output files).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace rumi {

class Se3 {
 public:
  Se3() : q_(Eigen::Quaterniond::Identity()), t_(Eigen::Vector3d::Zero()) {}
  Se3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : q_(q.normalized()), t_(t) {}
  Se3(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) : q_(Eigen::Quaterniond(R).normalized()), t_(t) {}
  static Se3 FromMatrix(const Eigen::Matrix4d& T);
  // Quaternion I/O in the two orders used by trajectory files.
  static Se3 FromTumXyzw(const Eigen::Vector3d& t, double qx, double qy, double qz, double qw);
  static Se3 FromWxyz(const Eigen::Vector3d& t, double qw, double qx, double qy, double qz);
  // Takes q as it is (already unit length, e.g. just deserialised), so that a
  // binary round trip is bit-exact; the normalising constructor may move 1 ulp.
  static Se3 FromUnitQuaternion(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
    Se3 T;
    T.q_ = q;
    T.t_ = t;
    return T;
  }

  const Eigen::Quaterniond& rotation() const { return q_; }
  Eigen::Matrix3d R() const { return q_.toRotationMatrix(); }
  const Eigen::Vector3d& translation() const { return t_; }
  Eigen::Vector3d& translation() { return t_; }
  void set_rotation(const Eigen::Quaterniond& q) { q_ = q.normalized(); }

  Se3 Inverse() const;
  Se3 operator*(const Se3& o) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return q_ * p + t_; }
  Eigen::Matrix4d Matrix() const;
  Eigen::Matrix<double, 3, 4> Matrix3x4() const;

  // Log/exp on the tangent (rho, phi) with the left-perturbation convention
  // used by the front's optimisers: Exp(xi) * T.
  static Se3 Exp(const Eigen::Matrix<double, 6, 1>& xi);
  Eigen::Matrix<double, 6, 1> Log() const;

 private:
  Eigen::Quaterniond q_;
  Eigen::Vector3d t_;
};

class Sim3 {
 public:
  Sim3() : s_(1.0) {}
  Sim3(double s, const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : s_(s), q_(q.normalized()), t_(t) {}
  explicit Sim3(const Se3& T, double s = 1.0) : s_(s), q_(T.rotation()), t_(T.translation()) {}
  static Sim3 FromMatrix(const Eigen::Matrix4d& S);

  double scale() const { return s_; }
  const Eigen::Quaterniond& rotation() const { return q_; }
  Eigen::Matrix3d R() const { return q_.toRotationMatrix(); }
  const Eigen::Vector3d& translation() const { return t_; }

  Sim3 Inverse() const;
  Sim3 operator*(const Sim3& o) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return s_ * (q_ * p) + t_; }
  Eigen::Matrix4d Matrix() const;

  // Maps a camera->world pose from this transform's source frame into its
  // target frame; the returned pose is rigid (scale moves the centre only).
  Se3 TransformPose(const Se3& T_wc) const;

 private:
  double s_;
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t_ = Eigen::Vector3d::Zero();
};

struct UmeyamaResult {
  Sim3 transform;                 // maps src into dst (scale 1 when !with_scale)
  std::vector<double> residuals;  // |dst_i - T * src_i|
  double rmse = 0.0;
  bool ok = false;  // false with < 3 points or degenerate (collinear) input
};

// Least-squares alignment of corresponding points (Umeyama 1991).
UmeyamaResult UmeyamaAlign(const std::vector<Eigen::Vector3d>& src,
                           const std::vector<Eigen::Vector3d>& dst, bool with_scale);

// Rotation angle of R in radians.
double RotationAngle(const Eigen::Quaterniond& q);

}  // namespace rumi
