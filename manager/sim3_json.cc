#include "manager/sim3_json.h"

namespace rumi {

nlohmann::json Sim3ToJson(const Sim3& S) {
  const auto& q = S.rotation();
  const auto& t = S.translation();
  return {{"s", S.scale()}, {"q_xyzw", {q.x(), q.y(), q.z(), q.w()}}, {"t", {t.x(), t.y(), t.z()}}};
}

Sim3 Sim3FromJson(const nlohmann::json& j) {
  const auto& q = j.at("q_xyzw");
  const auto& t = j.at("t");
  return Sim3(j.at("s").get<double>(),
              Eigen::Quaterniond(q.at(3).get<double>(), q.at(0).get<double>(), q.at(1).get<double>(),
                                 q.at(2).get<double>()),
              Eigen::Vector3d(t.at(0).get<double>(), t.at(1).get<double>(), t.at(2).get<double>()));
}

}  // namespace rumi
