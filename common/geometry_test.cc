#include "common/geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rumi {
namespace {

class GeometryTest : public ::testing::Test {
 protected:
  Eigen::Vector3d RandomVector(double scale = 1.0) {
    std::uniform_real_distribution<double> u(-scale, scale);
    return Eigen::Vector3d(u(rng_), u(rng_), u(rng_));
  }
  Eigen::Quaterniond RandomRotation() {
    std::normal_distribution<double> n(0, 1);
    return Eigen::Quaterniond(n(rng_), n(rng_), n(rng_), n(rng_)).normalized();
  }
  Se3 RandomSe3() { return Se3(RandomRotation(), RandomVector(5.0)); }
  Sim3 RandomSim3() {
    std::uniform_real_distribution<double> s(0.2, 5.0);
    return Sim3(s(rng_), RandomRotation(), RandomVector(5.0));
  }
  std::mt19937 rng_{42};
};

Eigen::Matrix4d Hat4(const Eigen::Matrix<double, 6, 1>& xi) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m(0, 1) = -xi(5);
  m(0, 2) = xi(4);
  m(1, 0) = xi(5);
  m(1, 2) = -xi(3);
  m(2, 0) = -xi(4);
  m(2, 1) = xi(3);
  m.block<3, 1>(0, 3) = xi.head<3>();
  return m;
}

TEST_F(GeometryTest, Se3ComposeInverseActAgreeWithMatrices) {
  for (int i = 0; i < 50; ++i) {
    const Se3 A = RandomSe3(), B = RandomSe3();
    const Eigen::Vector3d p = RandomVector(3.0);
    EXPECT_TRUE((A * B).Matrix().isApprox(A.Matrix() * B.Matrix(), 1e-12));
    EXPECT_TRUE(A.Inverse().Matrix().isApprox(A.Matrix().inverse(), 1e-12));
    EXPECT_TRUE((A * A.Inverse()).Matrix().isApprox(Eigen::Matrix4d::Identity(), 1e-12));
    EXPECT_TRUE(((A * B) * p).isApprox(A * (B * p), 1e-12));
    const Eigen::Vector4d ph = A.Matrix() * p.homogeneous();
    EXPECT_TRUE((A * p).isApprox(ph.head<3>(), 1e-12));
    EXPECT_TRUE((A * p).isApprox(A.R() * p + A.translation(), 1e-12));
    EXPECT_TRUE(Se3::FromMatrix(A.Matrix()).Matrix().isApprox(A.Matrix(), 1e-12));
    EXPECT_TRUE(A.Matrix3x4().isApprox(A.Matrix().topRows<3>(), 0.0));
  }
}

TEST_F(GeometryTest, QuaternionOrderHelpers) {
  const Eigen::Quaterniond q = RandomRotation();
  const Eigen::Vector3d t(1, -2, 3);
  const Se3 a = Se3::FromTumXyzw(t, q.x(), q.y(), q.z(), q.w());
  const Se3 b = Se3::FromWxyz(t, q.w(), q.x(), q.y(), q.z());
  EXPECT_TRUE(a.Matrix().isApprox(b.Matrix(), 1e-14));
  EXPECT_TRUE(a.R().isApprox(q.toRotationMatrix(), 1e-14));
  // The same four numbers in the other order are a different rotation.
  const Se3 swapped = Se3::FromWxyz(t, q.x(), q.y(), q.z(), q.w());
  EXPECT_FALSE(a.R().isApprox(swapped.R(), 1e-3));
  // Unnormalised input is normalised.
  const Se3 c = Se3::FromTumXyzw(t, 2 * q.x(), 2 * q.y(), 2 * q.z(), 2 * q.w());
  EXPECT_NEAR(c.rotation().norm(), 1.0, 1e-15);
}

TEST_F(GeometryTest, Se3ExpLogRoundTrip) {
  for (int i = 0; i < 100; ++i) {
    Eigen::Matrix<double, 6, 1> xi;
    xi.head<3>() = RandomVector(3.0);
    xi.tail<3>() = RandomVector(1.0);
    if (xi.tail<3>().norm() > 3.0) xi.tail<3>() *= 3.0 / xi.tail<3>().norm();
    const Se3 T = Se3::Exp(xi);
    EXPECT_TRUE(T.Log().isApprox(xi, 1e-10)) << xi.transpose() << "\n" << T.Log().transpose();
    const Se3 A = RandomSe3();
    EXPECT_TRUE(Se3::Exp(A.Log()).Matrix().isApprox(A.Matrix(), 1e-10));
  }
  // Near-identity and near-pi cases.
  Eigen::Matrix<double, 6, 1> tiny;
  tiny << 1e-3, -2e-3, 5e-4, 1e-12, -3e-12, 2e-12;
  EXPECT_TRUE(Se3::Exp(tiny).Log().isApprox(tiny, 1e-9));
  Eigen::Matrix<double, 6, 1> big;
  big << 0.5, 0.2, -0.1, 0, 0, M_PI - 1e-6;
  EXPECT_TRUE(Se3::Exp(big).Log().isApprox(big, 1e-8));
  EXPECT_TRUE(Se3().Log().isZero(0.0));
}

TEST_F(GeometryTest, Se3ExpMatchesTwistGenerator) {
  // Pure rotation and pure translation, and first order: Exp(e*xi) ~ I + e*hat(xi).
  Eigen::Matrix<double, 6, 1> rot;
  rot << 0, 0, 0, 0, 0, M_PI / 2;
  EXPECT_TRUE((Se3::Exp(rot) * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  Eigen::Matrix<double, 6, 1> tr;
  tr << 1, -2, 3, 0, 0, 0;
  EXPECT_TRUE(Se3::Exp(tr).translation().isApprox(Eigen::Vector3d(1, -2, 3), 1e-15));
  Eigen::Matrix<double, 6, 1> xi;
  xi << 0.3, -0.7, 0.2, 0.4, 0.1, -0.5;
  const double e = 1e-6;
  const Eigen::Matrix4d d = (Se3::Exp(e * xi).Matrix() - Eigen::Matrix4d::Identity()) / e;
  EXPECT_TRUE(d.isApprox(Hat4(xi), 1e-5)) << d << "\n" << Hat4(xi);
  // Exp(xi) of a screw motion: rotation about z while moving along it and
  // with an offset axis: the centre must lie on the helix.
  Eigen::Matrix<double, 6, 1> screw;
  screw << 0, 0, 1, 0, 0, M_PI;  // half turn, 1 along z, axis through origin
  EXPECT_TRUE(Se3::Exp(screw).translation().isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
}

TEST_F(GeometryTest, Sim3ComposeInverseActAgreeWithMatrices) {
  for (int i = 0; i < 50; ++i) {
    const Sim3 A = RandomSim3(), B = RandomSim3();
    const Eigen::Vector3d p = RandomVector(3.0);
    EXPECT_TRUE((A * B).Matrix().isApprox(A.Matrix() * B.Matrix(), 1e-12));
    EXPECT_TRUE(A.Inverse().Matrix().isApprox(A.Matrix().inverse(), 1e-12));
    EXPECT_NEAR((A * A.Inverse()).scale(), 1.0, 1e-14);
    EXPECT_TRUE(((A * B) * p).isApprox(A * (B * p), 1e-12));
    EXPECT_TRUE((A * p).isApprox(A.scale() * (A.R() * p) + A.translation(), 1e-12));
    const Sim3 back = Sim3::FromMatrix(A.Matrix());
    EXPECT_NEAR(back.scale(), A.scale(), 1e-12);
    EXPECT_TRUE(back.Matrix().isApprox(A.Matrix(), 1e-12));
  }
}

TEST_F(GeometryTest, Sim3TransformPoseMovesCentreKeepsRigidity) {
  const Sim3 S = RandomSim3();
  const Se3 T = RandomSe3();
  const Se3 U = S.TransformPose(T);
  EXPECT_TRUE(U.translation().isApprox(S * T.translation(), 1e-12));
  EXPECT_TRUE(U.R().isApprox(S.R() * T.R(), 1e-12));
  // Same as the Se3 part of S * T (the scale only moves the camera centre).
  const Sim3 ST = S * Sim3(T);
  EXPECT_TRUE(U.translation().isApprox(ST.translation(), 1e-12));
  EXPECT_TRUE(U.R().isApprox(ST.R(), 1e-12));
  EXPECT_NEAR(U.R().determinant(), 1.0, 1e-12);
}

TEST_F(GeometryTest, UmeyamaRecoversKnownSim3Exactly) {
  for (int trial = 0; trial < 20; ++trial) {
    const Sim3 S = RandomSim3();
    std::vector<Eigen::Vector3d> src, dst;
    for (int i = 0; i < 30; ++i) {
      src.push_back(RandomVector(10.0));
      dst.push_back(S * src.back());
    }
    const UmeyamaResult r = UmeyamaAlign(src, dst, true);
    ASSERT_TRUE(r.ok);
    EXPECT_NEAR(r.transform.scale(), S.scale(), 1e-10 * S.scale());
    EXPECT_TRUE(r.transform.Matrix().isApprox(S.Matrix(), 1e-10));
    EXPECT_LT(r.rmse, 1e-9);
    ASSERT_EQ(r.residuals.size(), src.size());
    // Without scale on the same data: scale stays 1 and the fit is worse
    // unless the drawn scale (in [0.2, 5]) happens to be near 1.
    const UmeyamaResult rigid = UmeyamaAlign(src, dst, false);
    ASSERT_TRUE(rigid.ok);
    EXPECT_EQ(rigid.transform.scale(), 1.0);
    if (std::abs(S.scale() - 1.0) > 0.1) {
      EXPECT_GT(rigid.rmse, 0.1);
    }
  }
}

TEST_F(GeometryTest, UmeyamaRecoversKnownSe3WithoutScale) {
  const Se3 T = RandomSe3();
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 10; ++i) {
    src.push_back(RandomVector(2.0));
    dst.push_back(T * src.back());
  }
  const UmeyamaResult r = UmeyamaAlign(src, dst, false);
  ASSERT_TRUE(r.ok);
  EXPECT_TRUE(r.transform.Matrix().isApprox(T.Matrix(), 1e-10));
  // With scale on rigid data the scale comes out 1.
  EXPECT_NEAR(UmeyamaAlign(src, dst, true).transform.scale(), 1.0, 1e-10);
  // Exactly three non-collinear points are enough.
  src.resize(3);
  dst.resize(3);
  const UmeyamaResult three = UmeyamaAlign(src, dst, false);
  ASSERT_TRUE(three.ok);
  EXPECT_TRUE(three.transform.Matrix().isApprox(T.Matrix(), 1e-9));
}

TEST_F(GeometryTest, UmeyamaNeverReturnsAReflection) {
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 20; ++i) {
    src.push_back(RandomVector(2.0));
    dst.push_back(Eigen::Vector3d(src.back().x(), src.back().y(), -src.back().z()));
  }
  const UmeyamaResult r = UmeyamaAlign(src, dst, true);
  ASSERT_TRUE(r.ok);
  EXPECT_NEAR(r.transform.R().determinant(), 1.0, 1e-12);
  EXPECT_GT(r.rmse, 0.1);  // a mirror cannot be fitted
}

TEST_F(GeometryTest, UmeyamaDegenerateInputIsNotOk) {
  std::vector<Eigen::Vector3d> src = {{0, 0, 0}, {1, 0, 0}}, dst = src;
  EXPECT_FALSE(UmeyamaAlign(src, dst, true).ok);  // two points
  src = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}};
  dst = src;
  EXPECT_FALSE(UmeyamaAlign(src, dst, true).ok);  // collinear
  EXPECT_FALSE(UmeyamaAlign(src, dst, false).ok);
  src.assign(5, Eigen::Vector3d(1, 2, 3));
  dst = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  EXPECT_FALSE(UmeyamaAlign(src, dst, true).ok);  // all source points coincide
  src = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  dst = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_FALSE(UmeyamaAlign(src, dst, true).ok);  // size mismatch
  EXPECT_FALSE(UmeyamaAlign({}, {}, true).ok);
}

TEST_F(GeometryTest, RotationAngle) {
  for (double a : {0.0, 0.1, 1.0, 2.5, M_PI}) {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(a, Eigen::Vector3d(1, 2, 3).normalized()));
    EXPECT_NEAR(RotationAngle(q), a, 1e-12);
    EXPECT_NEAR(RotationAngle(Eigen::Quaterniond(-q.coeffs())), a, 1e-12);  // q and -q
  }
}

}  // namespace
}  // namespace rumi
