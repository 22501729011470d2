// The formfactor queries reader (io/queries.h): valid documents, and errors that name the query.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "io/queries.h"
#include "scratch_dir.h"
#include "util/error.h"

using namespace photometria;
using nlohmann::json;

namespace {

std::string error_of(const std::string& text) {
  try {
    parse_queries(json::parse(text), "q.json");
  } catch (const Error& e) {
    EXPECT_EQ(e.exit_code(), 1);
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(Queries, ParsesTheThreeKindsOfDesignMd) {
  const auto qs = parse_queries(json::parse(R"({"queries": [
    {"id": "q1", "point": [0,0,0], "normal": [0,0,2], "polygon": [[-1,-1,1],[1,-1,1],[1,1,1],[-1,1,1]]},
    {"id": "q2", "point": [0,0,0], "normal": [0,0,1], "sphere": {"center": [0,0,3], "radius": 1, "intensity": 5}},
    {"id": "q3", "point": [0,0,0], "normal": [0,0,1], "distant": {"direction": [0,0,1], "angle_deg": 0.53, "normalize": true}}
  ]})"),
                                "q.json");
  ASSERT_EQ(qs.size(), 3u);
  EXPECT_EQ(qs[0].kind, PointQuery::Kind::Polygon);
  EXPECT_EQ(qs[0].polygon.size(), 4u);
  EXPECT_TRUE(qs[0].normal.isApprox(Vec3::UnitZ()));  // normalized
  EXPECT_EQ(qs[1].kind, PointQuery::Kind::Sphere);
  EXPECT_EQ(qs[1].radius, 1.0);
  EXPECT_EQ(*qs[1].intensity, 5.0);
  EXPECT_EQ(qs[2].kind, PointQuery::Kind::Distant);
  EXPECT_EQ(qs[2].angle_deg, 0.53);
  EXPECT_TRUE(qs[2].normalize);
  EXPECT_FALSE(qs[2].intensity.has_value());
}

TEST(Queries, ErrorsNameTheQueryIdAndTheValue) {
  const std::string base = R"("point": [0,0,0], "normal": [0,0,1])";
  auto q = [&](const std::string& id, const std::string& body) {
    return R"({"queries": [{"id": "ok", )" + base + R"(, "sphere": {"center": [0,0,3], "radius": 1}}, {"id": ")" + id +
           R"(", )" + body + "}]}";
  };
  std::string m = error_of(q("bad", base + R"(, "sphere": {"center": [0,0,3], "radius": -1})"));
  EXPECT_NE(m.find("q.json: query 2 (id \"bad\"): 'radius' must be > 0, got -1"), std::string::npos) << m;
  m = error_of(q("in", base + R"(, "sphere": {"center": [0,0,0.5], "radius": 1})"));
  EXPECT_NE(m.find("(id \"in\"): the point lies inside the sphere"), std::string::npos) << m;
  m = error_of(q("n0", R"("point": [0,0,0], "normal": [0,0,0], "polygon": [[0,0,1],[1,0,1],[1,1,1]])"));
  EXPECT_NE(m.find("(id \"n0\"): 'normal' must be a non-zero vector"), std::string::npos) << m;
  m = error_of(
      q("two", base + R"(, "polygon": [[0,0,1],[1,0,1],[1,1,1]], "sphere": {"center": [0,0,3], "radius": 1})"));
  EXPECT_NE(m.find("(id \"two\"): needs exactly one of"), std::string::npos) << m;
  m = error_of(q("p2", base + R"(, "polygon": [[0,0,1],[1,0,1]])"));
  EXPECT_NE(m.find("(id \"p2\"): 'polygon' must be an array of at least 3 vertices"), std::string::npos) << m;
  m = error_of(q("pv", base + R"(, "polygon": [[0,0,1],[1,0],[1,1,1]])"));
  EXPECT_NE(m.find("(id \"pv\"): 'polygon[1]' must be an array of 3 numbers"), std::string::npos) << m;
  m = error_of(q("ang", base + R"(, "distant": {"direction": [0,0,1], "angle_deg": 400})"));
  EXPECT_NE(m.find("(id \"ang\"): 'angle_deg' must be in [0, 360], got 400"), std::string::npos) << m;
  m = error_of(q("key", base + R"(, "distant": {"direction": [0,0,1], "angle": 1})"));
  EXPECT_NE(m.find("(id \"key\"): distant: unknown key 'angle'"), std::string::npos) << m;
  m = error_of(q("ok", base + R"(, "distant": {"direction": [0,0,1], "angle_deg": 1})"));
  EXPECT_NE(m.find("(id \"ok\"): duplicate id"), std::string::npos) << m;
  m = error_of(R"({"queries": [{"point": [0,0,0]}]})");
  EXPECT_NE(m.find("query 1: 'id' must be a non-empty string"), std::string::npos) << m;
  EXPECT_NE(error_of(R"({"query": []})").find("expected {\"queries\": [...]}"), std::string::npos);
  EXPECT_NE(error_of(R"({"queries": []})").find("'queries' is empty"), std::string::npos);
}

TEST(Queries, LoadReportsTheLineOfBadJsonAndMissingFiles) {
  const auto dir = test_scratch::fresh_dir("pm_queries_");
  const std::string path = (dir / "bad.json").string();
  std::ofstream(path) << "{\"queries\": [\n  {\"id\": \"q1\",\n   \"point\": [0, 0, 0,]\n}]}\n";
  try {
    load_queries(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.exit_code(), 1);
    EXPECT_NE(std::string(e.what()).find(path + ":3:"), std::string::npos) << e.what();
  }
  try {
    load_queries((dir / "missing.json").string());
    FAIL() << "no error";
  } catch (const Error& e) { EXPECT_EQ(e.exit_code(), 2); }
  std::filesystem::remove_all(dir);
}

TEST(Queries, SeventeenSignificantDigitsRoundTrip) {
  EXPECT_EQ(format_double(0.1), "0.10000000000000001");
  EXPECT_EQ(format_double(0.25), "0.25000000000000000");
  EXPECT_EQ(format_double(0.0), "0.0000000000000000");
  EXPECT_EQ(format_double(1.5e-05), "1.5000000000000000e-05");
  for (double v : {0.13853160599489299678, 1.729787532502444e-05, 1.0 / 3.0, 8e-9})
    EXPECT_EQ(std::stod(format_double(v)), v);
  EXPECT_EQ(json_string("a\"b"), "\"a\\\"b\"");
}
