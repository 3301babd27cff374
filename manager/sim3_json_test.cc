#include "manager/sim3_json.h"

#include <gtest/gtest.h>

#include "manager/testing/synthetic_submaps.h"

namespace rumi {
namespace {

TEST(Sim3Json, RoundTripAndMissingKeys) {
  const Sim3 S = RandomSim3(5);
  const nlohmann::json j = Sim3ToJson(S);
  EXPECT_EQ(j["q_xyzw"].size(), 4u);
  EXPECT_TRUE(Sim3FromJson(nlohmann::json::parse(j.dump())).Matrix().isApprox(S.Matrix(), 1e-12));
  nlohmann::json bad = j;
  bad.erase("t");
  EXPECT_THROW(Sim3FromJson(bad), nlohmann::json::exception);
  bad = j;
  bad["s"] = "two";
  EXPECT_THROW(Sim3FromJson(bad), nlohmann::json::exception);
}

}  // namespace
}  // namespace rumi
