// End-to-end: `photometria formfactor` on the point-query example of docs/usage.md (its square
// listed in the other vertex order) and the analytic references.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_run.h"
#include "refs.h"
#include "scratch_dir.h"

namespace fs = std::filesystem;

namespace {

using cli_test::CliRun;

fs::path scratch() { return test_scratch::process_dir("photometria_ff_"); }

CliRun run(const std::string& args) { return cli_test::run_cli(args, (scratch() / "stderr.txt").string()); }

std::string write(const std::string& name, const std::string& text) {
  const fs::path p = scratch() / name;
  std::ofstream(p) << text;
  return p.string();
}

std::vector<nlohmann::json> lines(const std::string& out) {
  std::vector<nlohmann::json> v;
  std::stringstream s(out);
  std::string line;
  while (std::getline(s, line)) v.push_back(nlohmann::json::parse(line));
  return v;
}

}  // namespace

TEST(CliFormFactor, DesignExampleOneLinePerQuery) {
  const std::string q = write("design.json", R"({"queries": [
  {"id": "q1", "point": [0,0,0], "normal": [0,0,1], "polygon": [[-1,-1,1],[1,-1,1],[1,1,1],[-1,1,1]]},
  {"id": "q2", "point": [0,0,0], "normal": [0,0,1], "sphere": {"center": [0,0,3], "radius": 1}},
  {"id": "q3", "point": [0,0,0], "normal": [0,0,1], "distant": {"direction": [0,0,1], "angle_deg": 0.53, "intensity": 1000, "normalize": true}}
]})");
  const CliRun r = run("formfactor " + q);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto v = lines(r.out);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[0]["id"], "q1");
  // q1: the example's square [-1,1]² at z = 1 without a front_normal emits towards the receiver
  // in either vertex order: 4 × Howell B-3 with X = Y = 1... for the half-width 1 at c = 1:
  // 4 × B-3(X = 1, Y = 1) = 4 × 0.138531605994893 = 0.554126423979572. q2: (r/d)² = 1/9.
  EXPECT_NEAR(v[0]["form_factor"].get<double>(), 4 * 0.13853160599489299678, 1e-15);
  EXPECT_NEAR(v[1]["form_factor"].get<double>(), 1.0 / 9.0, 1e-16);
  EXPECT_NEAR(v[2]["irradiance"].get<double>(), 1000.0, 1e-9);  // UsdLux normalize: intensity = illuminance
  // 17 significant digits on the line.
  EXPECT_NE(r.out.find("\"form_factor\": 0.11111111111111110"), std::string::npos) << r.out;
}

TEST(CliFormFactor, EveryKernelOnTheReferences) {
  std::string text = "{\"queries\": [";
  std::vector<long double> want;
  for (const auto& c : refs::all()["cases"]) {
    if (c["kind"] != "point_polygon") continue;
    const auto& g = c["geometry"];
    nlohmann::json q = {{"id", c["id"]},
                        {"point", g["receiver"]["point"]},
                        {"normal", g["receiver"]["normal"]},
                        {"polygon", g["polygon"]}};
    if (!want.empty()) text += ",";
    text += q.dump();
    want.push_back(refs::number(c["value"]));
  }
  const std::string q = write("refs.json", text + "]}");
  for (const char* k :
       {"", " --kernel iwanicki", " --kernel lambert", " --kernel stark-vertex", " --kernel stark-image"}) {
    const CliRun r = run("formfactor " + q + k);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto v = lines(r.out);
    ASSERT_EQ(v.size(), want.size());
    for (size_t i = 0; i < v.size(); ++i) {
      const double f = v[i]["form_factor"].get<double>();
      if (want[i] < 1e-3L) EXPECT_LE(std::abs(f - want[i]), 1e-15L) << v[i]["id"] << k;
      else EXPECT_LE(std::abs(f / want[i] - 1), 1e-12L) << v[i]["id"] << k;
    }
  }
  // An approximation prints its error against the exact value.
  const CliRun r = run("formfactor " + q + " --kernel point-source");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto v = lines(r.out);
  ASSERT_EQ(v.size(), want.size());
  EXPECT_EQ(v[0]["kernel"], "point-source");
  EXPECT_NEAR(v[0]["exact"].get<double>(), double(want[0]), 1e-15);
  EXPECT_NEAR(v[0]["error"].get<double>(), v[0]["form_factor"].get<double>() - v[0]["exact"].get<double>(), 1e-16);
}

TEST(CliFormFactor, BadInputNamesTheQueryAndExitsOne) {
  const std::string q = write("bad.json", R"({"queries": [
  {"id": "fine", "point": [0,0,0], "normal": [0,0,1], "sphere": {"center": [0,0,3], "radius": 1}},
  {"id": "lamp", "point": [0,0,0], "normal": [0,0,1], "sphere": {"center": [0,0,3], "radius": 0}}]})");
  CliRun r = run("formfactor " + q);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("query 2 (id \"lamp\"): 'radius' must be > 0"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
  r = run("formfactor " + q + " --kernel acos");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("unknown kernel 'acos'"), std::string::npos) << r.err;
  r = run("formfactor /no/such/queries.json");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(run("formfactor --help").exit_code, 0);
}

TEST(CliFormFactor, EitherOrderWithoutFrontNormalOneSidedWithIt) {
  const std::string q = write("sides.json", R"({"queries": [
  {"id": "ccw", "point": [0,0,0], "normal": [0,0,1], "polygon": [[0,1,1],[1,1,1],[1,0,1],[0,0,1]]},
  {"id": "cw", "point": [0,0,0], "normal": [0,0,1], "polygon": [[0,0,1],[1,0,1],[1,1,1],[0,1,1]]},
  {"id": "front", "point": [0,0,0], "normal": [0,0,1], "front_normal": [0,0,-1], "polygon": [[0,0,1],[1,0,1],[1,1,1],[0,1,1]]},
  {"id": "back", "point": [0,0,0], "normal": [0,0,1], "front_normal": [0,0,1], "polygon": [[0,1,1],[1,1,1],[1,0,1],[0,0,1]]}
]})");
  const CliRun r = run("formfactor " + q);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto v = lines(r.out);
  ASSERT_EQ(v.size(), 4u);
  const double b3 = 0.13853160599489299678;  // refs pp_B3_unit_square_corner
  EXPECT_NEAR(v[0]["form_factor"].get<double>(), b3, 1e-15);
  EXPECT_NEAR(v[1]["form_factor"].get<double>(), b3, 1e-15);
  EXPECT_NEAR(v[2]["form_factor"].get<double>(), b3, 1e-15);
  EXPECT_EQ(v[3]["form_factor"].get<double>(), 0.0);  // seen from its back
}

TEST(CliFormFactor, NumberBeyondDoubleIsABadInputNotACrash) {
  const std::string q = write("huge.json", R"({"queries": [{"id": "q1", "point": [0, 0, 1e999], "normal": [0, 0, 1],
    "polygon": [[-1, -1, 1], [1, -1, 1], [1, 1, 1]]}]})");
  const CliRun r = run("formfactor " + q);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("huge.json"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1e999"), std::string::npos) << r.err;
}
