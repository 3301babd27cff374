#include "front/initializer.h"

#include <gtest/gtest.h>

#include <random>

namespace rumi {
namespace {

struct Scene {
  std::vector<Eigen::Vector2d> p1, p2;
  Se3 T_21;
};

Eigen::Matrix3d K() {
  Eigen::Matrix3d k;
  k << 500, 0, 320, 0, 500, 240, 0, 0, 1;
  return k;
}

// Points in front of camera 1 (planar: all on z = 4 + 0.1 x), projected into
// both views with Gaussian pixel noise.
Scene MakeScene(const Se3& T_21, bool planar, double noise, int n = 400, unsigned seed = 3) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-2.5, 2.5), uy(-1.8, 1.8), uz(3.0, 8.0);
  std::normal_distribution<double> nz(0.0, noise);
  Scene s;
  s.T_21 = T_21;
  const Eigen::Matrix3d k = K();
  while (static_cast<int>(s.p1.size()) < n) {
    Eigen::Vector3d X(ux(rng), uy(rng), uz(rng));
    if (planar) X.z() = 4.0 + 0.1 * X.x();
    const Eigen::Vector3d X2 = T_21 * X;
    if (X2.z() <= 0.5) continue;
    const Eigen::Vector2d a = (k * X).hnormalized(), b = (k * X2).hnormalized();
    if (a.x() < 0 || a.x() > 640 || a.y() < 0 || a.y() > 480) continue;
    if (b.x() < 0 || b.x() > 640 || b.y() < 0 || b.y() > 480) continue;
    s.p1.push_back(a + Eigen::Vector2d(nz(rng), nz(rng)));
    s.p2.push_back(b + Eigen::Vector2d(nz(rng), nz(rng)));
  }
  return s;
}

Se3 Motion(double yaw_deg, const Eigen::Vector3d& t) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d(0.1, 1, 0.05).normalized()));
  return Se3(q, t);
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

// Tolerances for 0.5 px noise on an unrefined two-view estimate (the front
// refines with BA); a wrong sign or swapped solution is off by tens of degrees.
void ExpectMotion(const TwoViewResult& r, const Se3& truth, double rot_tol = 1.0, double dir_tol = 4.0) {
  const double rot_err = RotationAngle(r.T_21.rotation().inverse() * truth.rotation()) * 180 / M_PI;
  EXPECT_LT(rot_err, rot_tol);
  EXPECT_LT(AngleDeg(r.T_21.translation(), truth.translation()), dir_tol);  // sign matters
  EXPECT_NEAR(r.T_21.translation().norm(), 1.0, 1e-9);
}

TEST(TwoView, GeneralSceneSelectsEssential) {
  const Se3 truth = Motion(5.0, {0.4, 0.05, 0.1});
  const Scene s = MakeScene(truth, false, 0.5);
  TwoViewResult r;
  ASSERT_TRUE(ReconstructTwoView(s.p1, s.p2, K(), {}, &r));
  EXPECT_EQ(r.model, 'E');
  EXPECT_LT(r.score_ratio, 0.45);
  ExpectMotion(r, truth);
  EXPECT_GT(r.num_triangulated, 300);
  EXPECT_GT(r.parallax_deg, 1.0);
  // Triangulated points match the truth up to the baseline scale.
  const Scene clean = MakeScene(truth, false, 0.0);
  const double scale = truth.translation().norm();
  int checked = 0;
  for (size_t i = 0; i < r.points.size(); ++i) {
    if (!r.triangulated[i]) continue;
    const Eigen::Vector3d X = r.points[i] * scale;
    const Eigen::Vector2d u = (K() * X).hnormalized();
    EXPECT_LT((u - s.p1[i]).norm(), 3.0);
    EXPECT_GT(X.z(), 2.0);
    EXPECT_LT(X.z(), 10.0);
    ++checked;
  }
  EXPECT_GT(checked, 300);
}

TEST(TwoView, ExactWithoutNoise) {
  const Se3 truth = Motion(5.0, {0.4, 0.05, 0.1});
  const Scene s = MakeScene(truth, false, 0.0);
  TwoViewResult r;
  ASSERT_TRUE(ReconstructTwoView(s.p1, s.p2, K(), {}, &r));
  EXPECT_EQ(r.model, 'E');
  ExpectMotion(r, truth, 0.01, 0.05);
}

TEST(TwoView, PlanarSceneSelectsHomography) {
  const Se3 truth = Motion(-4.0, {-0.5, 0.1, 0.05});
  const Scene s = MakeScene(truth, true, 0.5);
  TwoViewResult r;
  ASSERT_TRUE(ReconstructTwoView(s.p1, s.p2, K(), {}, &r));
  EXPECT_EQ(r.model, 'H');
  EXPECT_GT(r.score_ratio, 0.45);
  ExpectMotion(r, truth);
}

TEST(TwoView, ForwardMotion) {
  const Se3 truth = Motion(1.0, {0.02, 0.0, 1.0});
  const Scene s = MakeScene(truth, false, 0.3);
  TwoViewResult r;
  ASSERT_TRUE(ReconstructTwoView(s.p1, s.p2, K(), {}, &r));
  ExpectMotion(r, truth);
}

TEST(TwoView, RefusesPureRotationAndTinyBaseline) {
  TwoViewResult r;
  const Scene rot = MakeScene(Motion(6.0, {0, 0, 0}), false, 0.5);
  EXPECT_FALSE(ReconstructTwoView(rot.p1, rot.p2, K(), {}, &r));
  const Scene tiny = MakeScene(Motion(0.5, {0.005, 0, 0}), false, 0.5);
  EXPECT_FALSE(ReconstructTwoView(tiny.p1, tiny.p2, K(), {}, &r));
}

TEST(TwoView, RefusesGarbage) {
  TwoViewResult r;
  std::vector<Eigen::Vector2d> a(5, Eigen::Vector2d(1, 2)), b(4, Eigen::Vector2d(1, 2));
  EXPECT_FALSE(ReconstructTwoView(a, b, K(), {}, &r));  // size mismatch
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, 640);
  std::vector<Eigen::Vector2d> p1, p2;
  for (int i = 0; i < 300; ++i) { p1.emplace_back(u(rng), u(rng) * 0.75); p2.emplace_back(u(rng), u(rng) * 0.75); }
  EXPECT_FALSE(ReconstructTwoView(p1, p2, K(), {}, &r));  // random matches
}

TEST(TwoView, TriangulateDltExact) {
  Eigen::Matrix<double, 3, 4> P1 = Eigen::Matrix<double, 3, 4>::Zero(), P2;
  P1.leftCols<3>().setIdentity();
  const Se3 T = Motion(10.0, {1, 0, 0});
  P2 = T.Matrix3x4();
  const Eigen::Vector3d X(0.3, -0.2, 5.0);
  const Eigen::Vector3d Y = TriangulateDlt(P1, P2, X.hnormalized(), (T * X).hnormalized());
  EXPECT_LT((X - Y).norm(), 1e-9);
}

}  // namespace
}  // namespace rumi
