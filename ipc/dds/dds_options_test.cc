#include "ipc/dds/dds_options.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

TEST(DdsOptionsTest, DefaultsAreValidAndLoopback) {
  DdsOptions o;
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  EXPECT_FALSE(o.enabled);
  EXPECT_EQ(o.interface, "lo");
  const std::string xml = DomainConfigXml(o);
  EXPECT_NE(xml.find("<NetworkInterface name=\"lo\"/>"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<SharedMemory><Enable>false</Enable></SharedMemory>"), std::string::npos) << xml;
}

TEST(DdsOptionsTest, AddressesAndNamesAreTold) {
  DdsOptions o;
  o.interface = "192.168.4.2";
  EXPECT_NE(DomainConfigXml(o).find("address=\"192.168.4.2\""), std::string::npos);
  o.interface = "wlan0";
  EXPECT_NE(DomainConfigXml(o).find("name=\"wlan0\""), std::string::npos);
  o.interface = "";
  EXPECT_EQ(DomainConfigXml(o).find("NetworkInterface"), std::string::npos);
}

TEST(DdsOptionsTest, RangesAndNamesAreChecked) {
  std::string why;
  DdsOptions o;
  o.domain_id = 233;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("domain_id"), std::string::npos) << why;
  o = DdsOptions();
  o.chunk_bytes = 8ll << 20;  // above the 4 MiB a sample may hold
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("chunk_bytes"), std::string::npos) << why;
  o = DdsOptions();
  o.topic_prefix = "robots//rat";
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("topic_prefix"), std::string::npos) << why;
  o.topic_prefix = "robots/rat 1";
  EXPECT_FALSE(o.Check(&why));
  o.interface = "lo\"/><x";
  o.topic_prefix = "";
  EXPECT_FALSE(o.Check(&why));  // nothing can be smuggled into Cyclone's XML
  EXPECT_NE(why.find("interface"), std::string::npos) << why;
}

TEST(DdsOptionsTest, TopicNamesPerInstanceAndRos) {
  DdsOptions o;
  DdsTopics t = TopicsFor(o, "rat-1");
  EXPECT_EQ(t.status, "rumi/rat-1/status");
  EXPECT_EQ(t.request, "rumi/rat-1/request");
  EXPECT_EQ(t.ros_map, "rt/rumi/rat_1/map");  // ROS names allow no '-'
  EXPECT_EQ(t.ros_pose, "rt/rumi/rat_1/pose");
  o.topic_prefix = "lab/rat";
  t = TopicsFor(o, "rat-1");
  EXPECT_EQ(t.reply, "lab/rat/reply");
  EXPECT_EQ(t.ros_path, "rt/lab/rat/path");
}

}  // namespace
}  // namespace rumi
