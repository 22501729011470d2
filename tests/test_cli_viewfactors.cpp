// End-to-end: `photometria viewfactors` on the View3D manual's cube (tests/data/view3d_cube.vs3):
// every output format, the --json summary, enforcement, sparse drops, point factors, bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace fs = std::filesystem;

namespace {

// Exact values (Howell C-11 and C-14, unit cube), against View3D's printed 0.199825 / 0.200044.
const double kOpposite = 0.19982489569838738, kAdjacent = 0.20004377607540315;

struct CliRun {
  int exit_code;
  std::string out, err;
};

fs::path scratch() {
  const fs::path dir = fs::temp_directory_path() / ("photometria_vf_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

CliRun run(const std::string& args) {
  const fs::path err_file = scratch() / "stderr.txt";
  const std::string cmd = std::string(PHOTOMETRIA_BINARY) + " " + args + " 2>" + err_file.string();
  CliRun r{0, {}, {}};
  FILE* pipe = popen(cmd.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream e(err_file);
  std::stringstream s;
  s << e.rdbuf();
  r.err = s.str();
  return r;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::vector<std::string>> csv(const fs::path& p) {
  std::vector<std::vector<std::string>> rows;
  std::stringstream s(slurp(p));
  std::string line;
  while (std::getline(s, line)) {
    std::vector<std::string> cells;
    std::stringstream ls(line);
    std::string c;
    while (std::getline(ls, c, ',')) cells.push_back(c);
    rows.push_back(cells);
  }
  return rows;
}

const std::string cube = std::string(PHOTOMETRIA_SOURCE_DIR) + "/tests/data/view3d_cube.vs3";
const int kOpp[6] = {1, 0, 4, 5, 2, 3};  // floor, ceiling, south, east, north, west

}  // namespace

TEST(CliViewFactors, ManualCubeDenseCsvBeatsView3d) {
  const fs::path out = scratch() / "cube.csv";
  const CliRun r = run("viewfactors " + cube + " -o " + out.string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = csv(out);
  ASSERT_EQ(rows.size(), 7u);
  EXPECT_EQ(rows[0], (std::vector<std::string>{"name", "area", "floor", "ceiling", "south", "east", "north", "west"}));
  for (int i = 0; i < 6; ++i) {
    ASSERT_EQ(rows[i + 1].size(), 8u);
    EXPECT_EQ(std::stod(rows[i + 1][1]), 1.0);
    for (int j = 0; j < 6; ++j) {
      const double f = std::stod(rows[i + 1][j + 2]);
      const double want = i == j ? 0.0 : j == kOpp[i] ? kOpposite : kAdjacent;
      // View3D prints 0.199825 / 0.200044: 1.0e-7 / 2.2e-7 off. Ours must do better.
      EXPECT_NEAR(f, want, 2e-8) << i << "," << j;
    }
  }
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["surfaces"], 6);
  EXPECT_EQ(j["patches"], 6);
  EXPECT_EQ(j["visibility"], "none");
  EXPECT_NEAR(j["checks"]["row_sum_min"].get<double>(), 1.0, 1e-7);
  EXPECT_NEAR(j["checks"]["row_sum_max"].get<double>(), 1.0, 1e-7);
  EXPECT_LE(j["checks"]["reciprocity_error_max"].get<double>(), 1e-9);
  EXPECT_EQ(j["pairs"]["per_pair_adaptive"].get<long long>() + j["pairs"]["per_pair_gauss"].get<long long>(), 30);
  EXPECT_TRUE(j.contains("seconds"));
  EXPECT_GT(j["peak_memory_bytes"].get<double>(), 0.0);
}

TEST(CliViewFactors, PatchLevelSparseBinaryAndView3dForms) {
  // Sparse at patch level with a threshold: the dropped row sums are reported and add up.
  const fs::path sp = scratch() / "cube.sparse";
  CliRun r = run("viewfactors " + cube + " --by patch --max-edge 0.5 --format sparse --threshold 0.03 -o " +
                 sp.string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["surfaces"], 24);
  EXPECT_GT(j["sparse"]["dropped"].get<long long>(), 0);
  const auto rows = csv(sp);
  double kept_row0 = 0.0;
  bool header = false;
  for (const auto& row : rows) {
    if (row.size() == 3 && row[0] == "i") { header = true; continue; }
    if (!header) continue;
    EXPECT_GE(std::stod(row[2]), 0.03);
    if (row[0] == "0") kept_row0 += std::stod(row[2]);
  }
  EXPECT_TRUE(header);
  EXPECT_LE(1.0 - kept_row0, j["sparse"]["dropped_row_sum_max"].get<double>() + 1e-7);

  // Binary: documented layout (docs/viewfactors.md, io/viewfactor_output.h).
  const fs::path bin = scratch() / "cube.bin";
  r = run("viewfactors " + cube + " --format binary -o " + bin.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string b = slurp(bin);
  ASSERT_GE(b.size(), 16u);
  EXPECT_EQ(std::memcmp(b.data(), "PMVF\0\0\0\1", 8), 0);
  uint64_t n = 0;
  std::memcpy(&n, b.data() + 8, 8);
  ASSERT_EQ(n, 6u);
  size_t pos = 16;
  std::vector<std::string> names;
  for (int k = 0; k < 6; ++k) {
    uint32_t len = 0;
    std::memcpy(&len, b.data() + pos, 4);
    names.emplace_back(b.data() + pos + 4, len);
    pos += 4 + len;
  }
  EXPECT_EQ(names[3], "east");
  ASSERT_EQ(b.size(), pos + 6 * 8 + 36 * 8);
  double f01 = 0.0;
  std::memcpy(&f01, b.data() + pos + 48 + 8, 8);
  EXPECT_NEAR(f01, kOpposite, 2e-8);

  // View3D-style text: six-decimal rows, the manual's printed values.
  const fs::path v3 = scratch() / "cube.vf";
  r = run("viewfactors " + cube + " --format view3d -o " + v3.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string t = slurp(v3);
  EXPECT_NE(t.find("F 3 6\n"), std::string::npos);
  EXPECT_NE(t.find("0.000000 0.199825 0.200044 0.200044 0.200044 0.200044  ! floor\n"), std::string::npos);
}

TEST(CliViewFactors, EnforcementAndPointFactors) {
  const fs::path out = scratch() / "enf.csv", pts = scratch() / "points.csv", pout = scratch() / "p.csv";
  std::ofstream(pts) << "x,y,z,nx,ny,nz,id\n0.5,0.5,0,0,0,1,centre\n";
  const CliRun r = run("viewfactors " + cube + " --max-edge 0.5 --enforce both --points " + pts.string() +
                       " --points-output " + pout.string() + " -o " + out.string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["enforcement"]["after"]["row_sum_min"].get<double>(), 1.0, 1e-13);
  EXPECT_NEAR(j["enforcement"]["after"]["row_sum_max"].get<double>(), 1.0, 1e-13);
  EXPECT_LE(j["enforcement"]["after"]["reciprocity_error_max"].get<double>(), 1e-15);
  EXPECT_LE(std::abs(j["enforcement"]["before"]["row_sum_min"].get<double>() - 1.0), 1e-6);
  const auto rows = csv(pout);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0][2], "ceiling");
  EXPECT_EQ(rows[1][0], "centre");
  // Howell B-5 by quadrants: a point at the floor's centre to the ceiling.
  const double s1 = std::sqrt(1.25);
  EXPECT_NEAR(std::stod(rows[1][2]), 4.0 / (2 * M_PI) * (2 * 0.5 / s1 * std::atan(0.5 / s1)), 1e-13);
}

TEST(CliViewFactors, BadInputIsRefused) {
  const fs::path out = scratch() / "x.csv";
  CliRun r = run("viewfactors " + cube + " --by wall -o " + out.string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--by"), std::string::npos);
  r = run("viewfactors " + cube + " --enforce always -o " + out.string());
  EXPECT_EQ(r.exit_code, 1);
  r = run("viewfactors " + cube + " -o /nonexistent-dir/x.csv");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(fs::exists(out));
}
