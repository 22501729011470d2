#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "io/atomic_file.h"
#include "io/viewfactor_output.h"
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

namespace {

std::string surface_name(int i) {
  std::string s(1, char('a' + i % 26));
  s.append(std::to_string(i));
  return s;
}

// The text written by `format` for F (names "a", "b", ...; areas 1, 2, ...), committed and read back.
std::string written(ViewFactorFormat format, const ViewFactorRows& F, double threshold = 0.0) {
  const fs::path target = test_scratch::fresh_dir("photometria_vfout_") / "F.txt";
  std::vector<std::string> names;
  std::vector<double> areas;
  for (int i = 0; i < F.rows(); ++i) {
    names.push_back(surface_name(i));
    areas.push_back(1.0 + i);
  }
  AtomicOutput out(target.string());
  write_view_factors(out, format, names, areas, F, threshold);
  out.commit();
  std::ifstream in(target);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Awkward doubles: tenths, thirds, the smallest normal and subnormal, values needing 17 digits.
ViewFactorRows awkward_matrix(int n) {
  const double values[] = {0.1,
                           1.0 / 3.0,
                           0.30000000000000004,
                           2.2250738585072014e-308,
                           4.9406564584124654e-324,
                           0.0,
                           1.0,
                           0.123456789012345678,
                           1e-7,
                           0.9999999999999999,
                           0.5,
                           7.0 / 9.0};
  ViewFactorRows F(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) F(i, j) = values[(i * 7 + j * 3) % 12] * (1.0 + 1e-3 * j);
  return F;
}

}  // namespace

// CSV values read back as the same doubles (shortest round-trip text), for more rows than one
// formatting block, in row order.
TEST(ViewFactorOutput, CsvRoundTripsEveryValueExactly) {
  const int n = 300;
  const ViewFactorRows F = awkward_matrix(n);
  std::istringstream in(written(ViewFactorFormat::Csv, F));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("name,area,a0,b1,", 0), 0u);
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(std::getline(in, line)) << "row " << i;
    std::istringstream cells(line);
    std::string cell;
    std::getline(cells, cell, ',');
    EXPECT_EQ(cell, surface_name(i));
    std::getline(cells, cell, ',');
    EXPECT_EQ(std::strtod(cell.c_str(), nullptr), 1.0 + i);
    for (int j = 0; j < n; ++j) {
      ASSERT_TRUE(std::getline(cells, cell, ',')) << i << "," << j;
      ASSERT_EQ(std::strtod(cell.c_str(), nullptr), F(i, j)) << i << "," << j << ": " << cell;
      ASSERT_LE(cell.size(), 24u);
    }
  }
  EXPECT_FALSE(std::getline(in, line));
}

// The view3d form prints what C's printf would of the single-precision values.
TEST(ViewFactorOutput, View3dFieldsEqualPrintfOfTheFloatValues) {
  const int n = 260;
  const ViewFactorRows F = awkward_matrix(n);
  std::istringstream in(written(ViewFactorFormat::View3d, F));
  std::string line;
  std::getline(in, line);  // header
  std::getline(in, line);  // areas
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", double(float(1.0)));
  EXPECT_EQ(line.substr(0, line.find(' ')), std::string(buf));
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(std::getline(in, line));
    std::string want;
    for (int j = 0; j < n; ++j) {
      std::snprintf(buf, sizeof buf, "%.6f", double(float(F(i, j))));
      if (j) want.push_back(' ');
      want.append(buf);
    }
    ASSERT_EQ(line, want) << "row " << i;
  }
  std::getline(in, line);  // emissivities
  EXPECT_EQ(line.substr(0, 6), "1.000 ");
}

// Sparse: the entries at or above the threshold in row order, the dropped ones summed per row.
TEST(ViewFactorOutput, SparseKeepsEntriesAboveTheThresholdInOrder) {
  const int n = 270;
  const ViewFactorRows F = awkward_matrix(n);
  const std::string text = written(ViewFactorFormat::Sparse, F, 0.2);
  std::istringstream in(text);
  std::string line;
  int comments = 0;
  while (std::getline(in, line) && line[0] == '#') ++comments;
  EXPECT_EQ(comments, n);
  EXPECT_EQ(line, "i,j,F");
  long long expected = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) expected += F(i, j) >= 0.2;
  long long count = 0;
  int last_i = -1, last_j = -1;
  while (std::getline(in, line)) {
    int i = 0, j = 0;
    double f = 0.0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%d,%d,%lf", &i, &j, &f), 3) << line;
    ASSERT_TRUE(i > last_i || (i == last_i && j > last_j)) << line;
    EXPECT_EQ(f, F(i, j));
    last_i = i;
    last_j = j;
    ++count;
  }
  EXPECT_EQ(count, expected);
}

// Progress: about every 1/256 of the rows (here every 2nd row of 600), rising, ending at 1.
TEST(ViewFactorOutput, ProgressRisesToOne) {
  const int n = 600;
  const ViewFactorRows F = awkward_matrix(n);
  const fs::path target = test_scratch::fresh_dir("photometria_vfprogress_") / "F.csv";
  std::vector<double> seen;
  AtomicOutput out(target.string());
  write_view_factors(out, ViewFactorFormat::Csv, std::vector<std::string>(size_t(n), "s"),
                     std::vector<double>(size_t(n), 1.0), F, 0.0, {}, [&](double f) { seen.push_back(f); });
  ASSERT_EQ(seen.size(), size_t(n / 2));
  for (size_t k = 0; k < seen.size(); ++k) EXPECT_DOUBLE_EQ(seen[k], 2.0 * double(k + 1) / n);
  EXPECT_EQ(seen.back(), 1.0);
}
