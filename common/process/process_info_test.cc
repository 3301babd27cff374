#include "common/process/process_info.h"

#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstring>
#include <memory>
#include <string>

namespace rumi {
namespace {

constexpr size_t kMiB = 1 << 20;

TEST(ProcessInfo, ResidentMemorySplitsPrivateAndSharedPages) {
  const ResidentMemory before = ResidentMemoryOf();
  ASSERT_GT(before.total_mib, 0);
  ASSERT_GE(before.private_mib, 0);
  ASSERT_GE(before.shared_mib, 0);

  // 64 MiB of touched heap is private.
  std::unique_ptr<char[]> heap(new char[64 * kMiB]);
  std::memset(heap.get(), 1, 64 * kMiB);
  const ResidentMemory with_heap = ResidentMemoryOf();
  EXPECT_GE(with_heap.private_mib - before.private_mib, 60);
  EXPECT_LT(with_heap.shared_mib - before.shared_mib, 4);

  // 32 MiB of a touched shared segment (as an ipc ring) is shared, not private.
  const std::string name = "/rumi_process_info_test_" + std::to_string(::getpid());
  const int fd = ::shm_open(name.c_str(), O_CREAT | O_RDWR | O_EXCL, 0600);
  ASSERT_GE(fd, 0);
  ::shm_unlink(name.c_str());
  ASSERT_EQ(::ftruncate(fd, 32 * kMiB), 0);
  void* p = ::mmap(nullptr, 32 * kMiB, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  ::close(fd);
  ASSERT_NE(p, MAP_FAILED);
  std::memset(p, 1, 32 * kMiB);
  const ResidentMemory with_shm = ResidentMemoryOf();
  EXPECT_GE(with_shm.shared_mib - with_heap.shared_mib, 30);
  EXPECT_LT(with_shm.private_mib - with_heap.private_mib, 4);
  EXPECT_GE(with_shm.total_mib - before.total_mib, 90);
  ::munmap(p, 32 * kMiB);
}

TEST(ProcessInfo, ResidentMemoryOfAMissingProcessIsUnknown) {
  const ResidentMemory m = ResidentMemoryOf(999999999);
  EXPECT_EQ(m.total_mib, -1);
  EXPECT_EQ(m.private_mib, -1);
  EXPECT_EQ(m.shared_mib, -1);
  EXPECT_EQ(ResidentMiB(999999999), -1);
}

}  // namespace
}  // namespace rumi
