// The manager -> front map notices (halt/resume in the hierarchical mode).
#include <gtest/gtest.h>
#include <unistd.h>

#include "ipc/channels.h"
#include "ipc/segments.h"

namespace rumi {
namespace {

TEST(MapNotices, TheFrontReadsTheNewestAndKeepsItsLastWhenNothingIsNew) {
  IpcOptions o;
  o.instance = "notice_test_" + std::to_string(::getpid());
  RemoveInstanceSegments(o.instance, true);
  MapNoticeReceiver rx(o);
  MapNotice n;
  EXPECT_NE(rx.ReceiveNewest(&n), PopStatus::kOk);  // no manager yet
  EXPECT_EQ(n.front_submap_upto, -1);
  {
    MapNoticeSender tx(o);
    for (int i = 0; i < 40; ++i) {  // more than the ring holds: the oldest go
      MapNotice m;
      m.front_submap_upto = 1000000 + i;
      m.front_submap_end = 5000 + i;
      m.components = i % 3;
      m.t = 77;
      EXPECT_NE(tx.Send(m), PushStatus::kTooLarge);
    }
    ASSERT_EQ(rx.ReceiveNewest(&n), PopStatus::kOk);
    EXPECT_EQ(n.front_submap_upto, 1000039);
    EXPECT_EQ(n.front_submap_end, 5039);
    EXPECT_EQ(n.components, 39 % 3);
    // Nothing new: *n keeps the last notice.
    EXPECT_NE(rx.ReceiveNewest(&n), PopStatus::kOk);
    EXPECT_EQ(n.front_submap_upto, 1000039);
  }
  EXPECT_TRUE(NewestWinsSegment(o.instance, SegmentName(o.instance, kMapNoticeChannel)));
  EXPECT_FALSE(NewestWinsSegment(o.instance, SegmentName(o.instance, kWindowChannel)));
  RemoveInstanceSegments(o.instance, true);
}

}  // namespace
}  // namespace rumi
