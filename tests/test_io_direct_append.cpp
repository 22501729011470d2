// Appending past the page cache (src/io/direct_append.h): the file holds exactly the bytes
// written through the stream before, appended, and written through the stream after, whether
// the file system takes O_DIRECT or not, for an unaligned start and sizes around the buffers'.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "io/atomic_file.h"
#include "io/direct_append.h"
#include "scratch_dir.h"
#include "util/error.h"

using namespace photometria;
namespace fs = std::filesystem;

namespace {

// Bytes that differ from position to position (a misplaced block shows).
std::string pattern(size_t n, unsigned seed) {
  std::string s(n, '\0');
  unsigned x = seed;
  for (size_t i = 0; i < n; ++i) {
    x = x * 1103515245u + 12345u;
    s[i] = static_cast<char>(x >> 24);
  }
  return s;
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Header through the stream, `sizes` appended one after the other, trailer through the stream.
std::string write_file(const fs::path& target, size_t header, const std::vector<size_t>& sizes, bool direct,
                       bool& went_direct) {
  std::string expected = pattern(header, 1);
  AtomicOutput out(target.string());
  out.stream().write(expected.data(), std::streamsize(expected.size()));
  {
    DirectAppender app(out, direct);
    unsigned seed = 2;
    for (size_t n : sizes) {
      const std::string part = pattern(n, seed++);
      app.append(part.data(), part.size());
      expected += part;
    }
    app.finish();
    went_direct = app.direct();
  }
  const std::string trailer = "the end\n";
  out.stream() << trailer;
  expected += trailer;
  out.commit();
  return expected;
}

}  // namespace

TEST(DirectAppend, BytesLandInOrderAroundTheBuffersAndAlignment) {
  const fs::path dir = test_scratch::fresh_dir("photometria_direct_");
  const size_t mib = size_t(1) << 20;
  // An unaligned header, pieces that cross the 8 MiB buffers and 4 KiB blocks, and a long one.
  const std::vector<std::vector<size_t>> cases = {
      {}, {1}, {4095, 1, 4096}, {8 * mib - 5000, 5000, 3}, {3 * mib, 17 * mib + 123, 2 * mib - 1}};
  for (bool direct : {true, false})
    for (size_t header : {size_t(0), size_t(5000), size_t(4096)})
      for (size_t c = 0; c < cases.size(); ++c) {
        const fs::path target = dir / ("out_" + std::to_string(c) + ".bin");
        bool went_direct = false;
        const std::string expected = write_file(target, header, cases[c], direct, went_direct);
        EXPECT_TRUE(read_all(target) == expected)
            << "case " << c << ", header " << header << ", direct " << direct << ": " << fs::file_size(target)
            << " bytes against " << expected.size();
        if (!direct) { EXPECT_FALSE(went_direct); }
      }
}

// An appender that is never finished leaves the temporary file behind for AtomicOutput to remove:
// nothing reaches the target.
TEST(DirectAppend, AnUnfinishedAppendCommitsNothing) {
  const fs::path target = test_scratch::fresh_dir("photometria_direct_") / "out.bin";
  std::string temp;
  {
    AtomicOutput out(target.string());
    temp = out.temp_path();
    DirectAppender app(out);
    const std::string part = pattern(9 << 20, 7);
    app.append(part.data(), part.size());
  }
  EXPECT_FALSE(fs::exists(temp));
  EXPECT_FALSE(fs::exists(target));
}
