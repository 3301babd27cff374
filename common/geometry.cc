#include "common/geometry.h"

#include <Eigen/SVD>
#include <cmath>

namespace rumi {
namespace {
Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}
}  // namespace

Se3 Se3::FromMatrix(const Eigen::Matrix4d& T) {
  return Se3(Eigen::Matrix3d(T.block<3, 3>(0, 0)), Eigen::Vector3d(T.block<3, 1>(0, 3)));
}

Se3 Se3::FromTumXyzw(const Eigen::Vector3d& t, double qx, double qy, double qz, double qw) {
  return Se3(Eigen::Quaterniond(qw, qx, qy, qz), t);
}

Se3 Se3::FromWxyz(const Eigen::Vector3d& t, double qw, double qx, double qy, double qz) {
  return Se3(Eigen::Quaterniond(qw, qx, qy, qz), t);
}

Se3 Se3::Inverse() const {
  const Eigen::Quaterniond qi = q_.conjugate();
  return Se3(qi, -(qi * t_));
}

Se3 Se3::operator*(const Se3& o) const { return Se3(q_ * o.q_, q_ * o.t_ + t_); }

Eigen::Matrix4d Se3::Matrix() const {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.block<3, 3>(0, 0) = R();
  T.block<3, 1>(0, 3) = t_;
  return T;
}

Eigen::Matrix<double, 3, 4> Se3::Matrix3x4() const { return Matrix().topRows<3>(); }

Se3 Se3::Exp(const Eigen::Matrix<double, 6, 1>& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  const double theta = phi.norm();
  Eigen::Matrix3d V = Eigen::Matrix3d::Identity();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  const Eigen::Matrix3d W = Hat(phi);
  if (theta < 1e-10) {
    V += 0.5 * W;
    q = Eigen::Quaterniond(1.0, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z());
  } else {
    V += (1 - std::cos(theta)) / (theta * theta) * W +
         (theta - std::sin(theta)) / (theta * theta * theta) * W * W;
    q = Eigen::Quaterniond(Eigen::AngleAxisd(theta, phi / theta));
  }
  return Se3(q, V * rho);
}

Eigen::Matrix<double, 6, 1> Se3::Log() const {
  const Eigen::AngleAxisd aa(q_);
  double theta = aa.angle();
  Eigen::Vector3d axis = aa.axis();
  if (theta > M_PI) {
    theta = 2 * M_PI - theta;
    axis = -axis;
  }
  const Eigen::Vector3d phi = theta * axis;
  const Eigen::Matrix3d W = Hat(phi);
  Eigen::Matrix3d Vinv = Eigen::Matrix3d::Identity() - 0.5 * W;
  if (theta > 1e-10) {
    const double half = 0.5 * theta;
    Vinv += (1.0 - half * std::cos(half) / std::sin(half)) / (theta * theta) * W * W;
  }
  Eigen::Matrix<double, 6, 1> xi;
  xi.head<3>() = Vinv * t_;
  xi.tail<3>() = phi;
  return xi;
}

Sim3 Sim3::FromMatrix(const Eigen::Matrix4d& S) {
  const Eigen::Matrix3d sR = S.block<3, 3>(0, 0);
  const double s = std::cbrt(sR.determinant());
  return Sim3(s, Eigen::Quaterniond(Eigen::Matrix3d(sR / s)), S.block<3, 1>(0, 3));
}

Sim3 Sim3::Inverse() const {
  const Eigen::Quaterniond qi = q_.conjugate();
  return Sim3(1.0 / s_, qi, -(qi * t_) / s_);
}

Sim3 Sim3::operator*(const Sim3& o) const {
  return Sim3(s_ * o.s_, q_ * o.q_, s_ * (q_ * o.t_) + t_);
}

Eigen::Matrix4d Sim3::Matrix() const {
  Eigen::Matrix4d S = Eigen::Matrix4d::Identity();
  S.block<3, 3>(0, 0) = s_ * R();
  S.block<3, 1>(0, 3) = t_;
  return S;
}

Se3 Sim3::TransformPose(const Se3& T_wc) const {
  return Se3(q_ * T_wc.rotation(), (*this) * T_wc.translation());
}

UmeyamaResult UmeyamaAlign(const std::vector<Eigen::Vector3d>& src,
                           const std::vector<Eigen::Vector3d>& dst, bool with_scale) {
  UmeyamaResult r;
  const size_t n = src.size();
  if (n < 3 || dst.size() != n) return r;
  Eigen::Vector3d mu_s = Eigen::Vector3d::Zero(), mu_d = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mu_s += src[i];
    mu_d += dst[i];
  }
  mu_s /= double(n);
  mu_d /= double(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double var_s = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = src[i] - mu_s, b = dst[i] - mu_d;
    cov += b * a.transpose();
    var_s += a.squaredNorm();
  }
  cov /= double(n);
  var_s /= double(n);
  if (var_s < 1e-20) return r;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();
  // Collinear points leave rotation about the line undetermined.
  if (d(1) < 1e-12 * std::max(1.0, d(0))) return r;
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixU() * S * svd.matrixV().transpose();
  const double s = with_scale ? (d.asDiagonal() * S).trace() / var_s : 1.0;
  const Eigen::Vector3d t = mu_d - s * R * mu_s;
  r.transform = Sim3(s, Eigen::Quaterniond(R), t);
  r.residuals.resize(n);
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    r.residuals[i] = (dst[i] - r.transform * src[i]).norm();
    sum += r.residuals[i] * r.residuals[i];
  }
  r.rmse = std::sqrt(sum / double(n));
  r.ok = true;
  return r;
}

double RotationAngle(const Eigen::Quaterniond& q) {
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
}

}  // namespace rumi
