#include "common/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

class AtomicFile : public ::testing::Test {
 protected:
  void SetUp() override { fs::create_directories(dir_.path()); }
  std::string P(const std::string& name) const { return dir_ / name; }
  std::string Slurp(const std::string& path) const {
    std::vector<uint8_t> b;
    std::string why;
    EXPECT_TRUE(ReadFileBytes(path, &b, &why)) << why;
    return std::string(b.begin(), b.end());
  }
  // Files in the folder besides `keep` (a temporary left behind).
  int Others(const std::string& keep) const {
    int n = 0;
    for (const auto& e : fs::directory_iterator(dir_.path())) n += e.path().filename() != keep;
    return n;
  }
  TempDir dir_;
};

TEST_F(AtomicFile, WritesReplacesAndKeepsItsMode) {
  std::string why;
  ASSERT_TRUE(WriteFileAtomically(P("a"), std::string("first"), &why)) << why;
  ASSERT_TRUE(WriteFileAtomically(P("a"), std::string("second"), &why, 0600)) << why;
  EXPECT_EQ(Slurp(P("a")), "second");
  struct stat st {};
  ASSERT_EQ(::stat(P("a").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(Others("a"), 0);
  // A folder that does not exist: a clear error naming the file.
  EXPECT_FALSE(WriteFileAtomically(P("none/b"), std::string("x"), &why));
  EXPECT_NE(why.find("none/b"), std::string::npos) << why;
}

// Text and bytes, binary-safe; a missing file names itself.
TEST_F(AtomicFile, ReadsWholeFilesAndSaysWhyNot) {
  std::string why, text;
  const std::string content("a\0b\r\nc", 6);
  ASSERT_TRUE(WriteFileAtomically(P("t"), content, &why)) << why;
  ASSERT_TRUE(ReadFileText(P("t"), &text, &why)) << why;
  EXPECT_EQ(text, content);
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(ReadFileBytes(P("t"), &bytes, &why)) << why;
  EXPECT_EQ(std::string(bytes.begin(), bytes.end()), content);
  EXPECT_FALSE(ReadFileText(P("missing"), &text, &why));
  EXPECT_NE(why.find("missing"), std::string::npos) << why;
  EXPECT_NE(why.find("cannot open"), std::string::npos) << why;
}

// Pieces appended, a header patched at the end from a checksum over what
// was written (read back through the mapping), then committed.
TEST_F(AtomicFile, AWriterInPiecesPatchesItsHeader) {
  std::string why;
  ASSERT_TRUE(WriteFileAtomically(P("m"), std::string("old"), &why)) << why;
  {
    AtomicFileWriter w(P("m"));
    ASSERT_TRUE(w.Append("HDR:????", 8));
    std::string body;
    for (int i = 0; i < 100000; ++i) body += char('a' + i % 26);  // more than a page
    for (size_t at = 0; at < body.size(); at += 4096)
      ASSERT_TRUE(w.Append(body.data() + at, std::min<size_t>(4096, body.size() - at)));
    EXPECT_EQ(w.size(), 8 + body.size());
    const auto view = w.Read(8, body.size());
    ASSERT_TRUE(view);
    EXPECT_EQ(std::memcmp(view->data(), body.data(), body.size()), 0);
    EXPECT_EQ(view->data()[body.size() - 1], body.back());
    EXPECT_FALSE(w.Read(8, body.size() + 1));  // beyond what was written
    EXPECT_EQ(Slurp(P("m")), "old");           // the target untouched until the commit
    ASSERT_TRUE(w.Patch(4, "1234", 4));
    ASSERT_TRUE(w.Commit(&why)) << why;
    const std::string got = Slurp(P("m"));
    EXPECT_EQ(got.substr(0, 8), "HDR:1234");
    EXPECT_EQ(got.substr(8), body);
  }
  EXPECT_EQ(Others("m"), 0);
}

TEST_F(AtomicFile, AWriterDroppedOrFailedLeavesTheTarget) {
  std::string why;
  ASSERT_TRUE(WriteFileAtomically(P("k"), std::string("kept"), &why)) << why;
  {
    AtomicFileWriter w(P("k"));
    ASSERT_TRUE(w.Append("half", 4));
  }  // dropped without a commit
  EXPECT_EQ(Slurp(P("k")), "kept");
  EXPECT_EQ(Others("k"), 0);
  AtomicFileWriter w(P("k"));
  ASSERT_TRUE(w.Append("abc", 3));
  EXPECT_FALSE(w.Patch(2, "xy", 2));  // beyond the end: an error, and every later call fails
  EXPECT_FALSE(w.Append("d", 1));
  EXPECT_NE(w.error().find("patch"), std::string::npos) << w.error();
  EXPECT_FALSE(w.Commit(&why));
  EXPECT_EQ(why, w.error());
  EXPECT_EQ(Slurp(P("k")), "kept");
  EXPECT_EQ(Others("k"), 0);
}

}  // namespace
}  // namespace rumi
