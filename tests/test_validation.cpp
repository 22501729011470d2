#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "refs.h"
#include "scratch_dir.h"
#include "validation/scenes.h"
#include "validation/suite.h"

using namespace photometria;
using namespace photometria::validation;

TEST(ValidationScenes, SphereCapFacesPointInwardAndCoverAQuarter) {
  const Scene s = sphere_cap_scene(12, 0.5);
  double cap = 0, total = 0;
  for (int f = 0; f < static_cast<int>(s.faces.size()); ++f) {
    const Polygon p = s.face_polygon(f);
    EXPECT_LT(polygon_normal(p).dot(polygon_centroid(p)), 0.0) << "face " << f;
    total += polygon_area(p);
    if (s.faces[f].material == 1) cap += polygon_area(p);
  }
  EXPECT_NEAR(cap / total, 0.25, 0.01);
}

TEST(Validation, QuickSuiteMeetsItsAccuracyAndErrorsFallWithRefinement) {
  std::vector<ValidationRow> rows = run_validation(refs::all(), {true, nullptr});
  std::map<std::string, std::vector<ValidationRow>> by;
  for (const auto& r : rows) by[r.scene].push_back(r);
  ASSERT_EQ(by["point-to-polygon (Lambert)"].size(), 1u);
  EXPECT_EQ(by["point-to-polygon (Lambert)"][0].cases, 17);
  EXPECT_LE(by["point-to-polygon (Lambert)"][0].max_rel_error, 1e-12);
  for (const std::string s :
       {"patch-to-patch (Howell C-11, C-14)", "cube 6x6, floor emitting", "sphere enclosure, emitting cap"}) {
    const auto& v = by[s];
    ASSERT_GE(v.size(), 2u) << s;
    EXPECT_LT(v.back().max_rel_error, v.front().max_rel_error) << s;
  }
  EXPECT_LT(by["patch-to-patch (Howell C-11, C-14)"].back().max_rel_error, 0.01);
  // Occluded patch to patch (exact visibility): rows n=1 q=1, n=1 q=4, n=4 q=1, n=4 q=4; the error
  // falls with the receiver rule at each mesh and the finest is far below the coarsest.
  const auto& occ = by["occluded patch-to-patch (exact visibility)"];
  ASSERT_EQ(occ.size(), 4u);
  EXPECT_LT(occ[1].max_rel_error, occ[0].max_rel_error);
  EXPECT_LT(occ[3].max_rel_error, occ[2].max_rel_error);
  EXPECT_LT(occ[3].max_rel_error, 1e-6);
  EXPECT_GT(occ[0].max_rel_error, 1e-2);  // the centroid of one patch is really wrong here
  for (const std::string s :
       {"white furnace rho=0.5", "white furnace rho=0.9", "white furnace rho=0.99", "white furnace rho=0.999"})
    for (const auto& r : by[s]) EXPECT_LE(r.max_rel_error, 1e-9) << s;
  // The hierarchical method's ladder: within the bounds (rms <= ε, max <= 5ε). The cube's
  // elements are rectangles of one frame, so every link's factor is the closed form and the rows
  // sum to 1 to rounding: what is left is the solve's stop (a relative change of 1e-8 per sweep,
  // at most ρ / (1 − ρ) = 9 times that from the fixed point), at every ε alike.
  const auto& hier = by["hierarchical: white furnace rho=0.9"];
  ASSERT_EQ(hier.size(), 2u);
  const double eps[2] = {1e-1, 3e-2};
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_LE(hier[k].rms_rel_error, eps[k]) << hier[k].setting;
    EXPECT_LE(hier[k].max_rel_error, 5 * eps[k]) << hier[k].setting;
    EXPECT_LE(hier[k].max_rel_error, 1e-7) << hier[k].setting;
    EXPECT_GT(hier[k].max_rel_error, 0.0) << hier[k].setting;  // not the exact furnace by construction
  }
}

TEST(Validation, WritesCsvAndPlot) {
  const auto dir = test_scratch::fresh_dir("photometria_validation_test_");
  const std::vector<ValidationRow> rows = {{"a", "x", 1, 1, 1, 1e-3, 1e-4, 0.01},
                                           {"a", "y", 4, 1, 1, 1e-5, 1e-6, 0.1},
                                           {"b", "x", 0, 1, 1, 0.0, 0.0, 0.001}};
  write_validation_csv((dir / "v.csv").string(), rows);
  std::ifstream in(dir / "v.csv");
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "scene,setting,patches,quadrature,cases,max_rel_error,rms_rel_error,seconds");
  write_error_vs_time_plot((dir / "v.csv").string(), (dir / "v.png").string(), rows);
  EXPECT_GT(std::filesystem::file_size(dir / "v.png"), 1000u);
  std::filesystem::remove_all(dir);
}
