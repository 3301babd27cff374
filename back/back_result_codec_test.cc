#include "back/back_result_codec.h"

#include <gtest/gtest.h>

#include "ipc/submap_codec.h"
#include "ipc/test_data.h"

namespace rumi {
namespace {

BackResult Sample() {
  BackResult r;
  r.window_id = 42;
  r.status = BackStatus::kOk;
  r.message = "";
  r.warnings = {"model 1 dropped (2 images)"};
  r.submaps = {ipc_test::MakeSubmap(4200), ipc_test::MakeSubmap(4201, 3, 10, 5)};
  r.submaps[0].source = r.submaps[1].source = SubmapSource::kBack;
  r.stats = {{6, 40, 120, 0.61, 3.0}, {3, 10, 30, 0.7, 3.0}};
  r.num_frames = 12;
  r.num_registered = 9;
  r.matched_pairs = 66;
  r.retried = true;
  r.fill_kept = true;
  r.times.matching_s = 3.25;
  r.times.mapping_cpu_s = 7.5;
  r.times.total_s = 12.125;
  return r;
}

TEST(BackResultCodec, RoundTripsEveryField) {
  const BackResult a = Sample();
  BackResult b;
  std::string why;
  const std::vector<uint8_t> bytes = EncodeBackResult(a);
  ASSERT_TRUE(DecodeBackResult(bytes.data(), bytes.size(), &b, &why)) << why;
  EXPECT_EQ(b.window_id, 42);
  EXPECT_EQ(b.status, BackStatus::kOk);
  EXPECT_EQ(b.warnings, a.warnings);
  EXPECT_EQ(b.num_frames, 12);
  EXPECT_EQ(b.num_registered, 9);
  EXPECT_EQ(b.matched_pairs, 66);
  EXPECT_TRUE(b.retried);
  EXPECT_FALSE(b.retry_kept);
  EXPECT_FALSE(b.filled);
  EXPECT_TRUE(b.fill_kept);
  EXPECT_EQ(b.times.matching_s, 3.25);
  EXPECT_EQ(b.times.mapping_cpu_s, 7.5);
  EXPECT_EQ(b.times.total_s, 12.125);
  ASSERT_EQ(b.submaps.size(), 2u);
  ASSERT_EQ(b.stats.size(), 2u);
  EXPECT_EQ(b.stats[1].num_observations, 30);
  EXPECT_EQ(b.stats[0].mean_reprojection_error_px, 0.61);
  for (size_t i = 0; i < 2; ++i) EXPECT_EQ(EncodeSubmap(b.submaps[i]), EncodeSubmap(a.submaps[i]));
  // A failure carries its message and no submap.
  BackResult f;
  f.window_id = 3;
  f.status = BackStatus::kTimeout;
  f.message = "mapper ran past 600 s";
  const std::vector<uint8_t> fb = EncodeBackResult(f);
  ASSERT_TRUE(DecodeBackResult(fb.data(), fb.size(), &b, &why)) << why;
  EXPECT_EQ(b.status, BackStatus::kTimeout);
  EXPECT_EQ(b.message, f.message);
  EXPECT_TRUE(b.submaps.empty());
}

TEST(BackResultCodec, RefusesCorruptTruncatedAndForeignInput) {
  const std::vector<uint8_t> good = EncodeBackResult(Sample());
  BackResult r;
  r.window_id = 99;
  std::string why;
  std::vector<uint8_t> bad = good;
  bad[bad.size() / 2] ^= 0x10;
  EXPECT_FALSE(DecodeBackResult(bad.data(), bad.size(), &r, &why));
  EXPECT_NE(why.find("checksum"), std::string::npos) << why;
  for (size_t n : {size_t{0}, size_t{7}, size_t{40}, good.size() - 1}) {
    EXPECT_FALSE(DecodeBackResult(good.data(), n, &r, &why)) << n;
    EXPECT_FALSE(why.empty());
  }
  bad = good;
  bad[0] = 'X';
  EXPECT_FALSE(DecodeBackResult(bad.data(), bad.size(), &r, &why));
  EXPECT_NE(why.find("magic"), std::string::npos) << why;
  bad = good;
  bad[4] = 9;  // version 9
  EXPECT_FALSE(DecodeBackResult(bad.data(), bad.size(), &r, &why));
  EXPECT_NE(why.find("version 9"), std::string::npos) << why;
  EXPECT_EQ(r.window_id, 99) << "a refused input leaves the result as it was";
}

}  // namespace
}  // namespace rumi
