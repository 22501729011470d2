#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

#include "io/atomic_file.h"
#include "io/vtu.h"
#include "scratch_dir.h"
#include "util/error.h"

using namespace photometria;
namespace fs = std::filesystem;

TEST(Vtu, RoundTripKeepsPointsCellsAndArrays) {
  const fs::path dir = test_scratch::fresh_dir("photometria_test_io_");
  const std::string path = (dir / "grid.vtu").string();
  VtuGrid g;
  g.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0, 0}};
  g.cells = {{0, 1, 2, 3}, {1, 4, 2}};
  g.point_arrays.push_back({"radiosity", 3, std::vector<double>(15, 0.25), false});
  g.cell_arrays.push_back({"area", 1, {1.0, 0.5}, false});
  g.cell_arrays.push_back({"face", 1, {7, 8}, true});
  write_vtu(path, g);
  EXPECT_FALSE(fs::exists(path + ".tmp-" + std::to_string(::getpid())));
  const VtuGrid back = read_vtu(path);
  ASSERT_EQ(back.points.size(), 5u);
  ASSERT_EQ(back.cells.size(), 2u);
  EXPECT_EQ(back.cells[1], (std::vector<int>{1, 4, 2}));
  ASSERT_EQ(back.point_arrays.size(), 1u);
  EXPECT_EQ(back.point_arrays[0].name, "radiosity");
  EXPECT_EQ(back.point_arrays[0].components, 3);
  EXPECT_EQ(back.point_arrays[0].values[14], 0.25);
  ASSERT_EQ(back.cell_arrays.size(), 2u);
  EXPECT_EQ(back.cell_arrays[1].values[1], 8);
  EXPECT_TRUE(back.cell_arrays[1].integer);
  fs::remove_all(dir);
}

TEST(AtomicOutput, UnwritableFolderIsAnIoErrorNamingThePath) {
  try {
    AtomicOutput out("/nonexistent-folder/x.vtu");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Io);
    EXPECT_NE(std::string(e.what()).find("/nonexistent-folder/x.vtu"), std::string::npos);
  }
}

TEST(AtomicOutput, NothingIsLeftWithoutCommit) {
  const fs::path target = test_scratch::fresh_dir("photometria_atomic_") / "out.vtu";
  fs::remove(target);
  std::string temp;
  {
    AtomicOutput out(target.string());
    temp = out.temp_path();
    EXPECT_TRUE(fs::exists(temp));
  }
  EXPECT_FALSE(fs::exists(temp));
  EXPECT_FALSE(fs::exists(target));
}
