// View3D .vs3 input: the manual's cube, an obstruction-only surface, refused parts named by line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "patching/patching.h"
#include "scene/scene.h"
#include "scratch_dir.h"
#include "util/error.h"
#include "viewfactors/viewfactors.h"

using namespace photometria;
namespace fs = std::filesystem;

namespace {

const std::string data = std::string(PHOTOMETRIA_SOURCE_DIR) + "/tests/data/";

std::string write_temp(const std::string& name, const std::string& text) {
  const fs::path p = test_scratch::process_dir("photometria_vs3_") / name;
  std::ofstream(p) << text;
  return p.string();
}

// The error message of loading `text`, "" if it loads.
std::string load_error(const std::string& text) {
  try {
    load_scene(write_temp("bad.vs3", text));
  } catch (const Error& e) {
    EXPECT_EQ(e.exit_code(), 1);
    return e.what();
  }
  return "";
}

const std::string header = "T t\nF 3\nV 1 0 0 0\nV 2 1 0 0\nV 3 1 1 0\nV 4 0 1 0\n";

}  // namespace

TEST(View3dInput, ReadsTheManualCube) {
  const Scene s = load_scene(data + "view3d_cube.vs3");
  EXPECT_EQ(s.vertices.size(), 8u);
  ASSERT_EQ(s.faces.size(), 6u);
  ASSERT_EQ(s.groups.size(), 6u);
  EXPECT_EQ(s.groups[s.faces[0].group], "floor");
  EXPECT_EQ(s.groups[s.faces[5].group], "west");
  EXPECT_EQ(s.faces[1].vertices, (std::vector<int>{4, 7, 6, 5}));
  EXPECT_EQ(s.stats.flipped_faces, 0);
  EXPECT_EQ(s.settings["view3d"]["encl"], 1.0);
  EXPECT_EQ(s.settings["view3d"]["eps"], 1e-4);
  EXPECT_NE(s.settings["title"].get<std::string>().find("Unit cube"), std::string::npos);
  for (const Face& f : s.faces) EXPECT_FALSE(f.obstruction_only);
  // Fronts face the inside: the floor's normal is +z.
  EXPECT_GT(polygon_normal(s.face_polygon(0)).z(), 0.9);
}

TEST(View3dInput, ObstructionOnlySurfaceBlocksButHasNoPatches) {
  const Scene s = load_scene(data + "view3d_obstructed.vs3");
  ASSERT_EQ(s.faces.size(), 3u);
  EXPECT_TRUE(s.faces[2].obstruction_only);
  EXPECT_EQ(s.groups[s.faces[2].group], "plate");
  const PatchViewFactors r = compute_view_factors(s, ViewFactorOptions{});
  ASSERT_EQ(r.mesh.size(), 2);
  EXPECT_EQ(r.visibility_mode, "exact");
  EXPECT_EQ(r.F(0, 1), 0.0);  // the plate covers the whole view
  const Aggregation agg = make_aggregation(s, r.mesh, AggregateLevel::Group);
  EXPECT_EQ(agg.names, (std::vector<std::string>{"bottom", "top"}));
  // Without the plate: Howell C-11, unit squares 1 apart.
  Scene open = s;
  open.faces.pop_back();
  const PatchViewFactors u = compute_view_factors(open, ViewFactorOptions{});
  EXPECT_NEAR(u.F(0, 1), 0.19982489569838738, 1e-7 * 0.2);
}

TEST(View3dInput, RefusesUnsupportedPartsNamingTheLine) {
  EXPECT_NE(load_error(header + "M 1 1 2 3 4 0 0 0.9 m\n").find("bad.vs3:7: mask (M)"), std::string::npos);
  EXPECT_NE(load_error(header + "N 1 1 2 3 4 0 0 0.9 m\n").find(":7: null (N)"), std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3 4 2 0 0.9 a\n").find(":7: subsurfaces"), std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3 4 0 1 0.9 a\n").find(":7: combined surfaces"), std::string::npos);
  EXPECT_NE(load_error("T t\nF 2\n").find("bad.vs3:2: unsupported geometry format '2'"), std::string::npos);
  EXPECT_NE(load_error("C eps=1e-4 foo=3\nF 3\n").find(":1: unsupported control key 'foo'"), std::string::npos);
  EXPECT_NE(load_error(header + "X 1\n").find(":7: unknown View3D record 'X'"), std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3 9 0 0 0.9 a\n").find(":7: vertex 9 not defined"), std::string::npos);
  EXPECT_NE(load_error("F 3\nV 2 0 0 0\n").find(":2: vertex number 2 out of sequence"), std::string::npos);
  EXPECT_NE(load_error("T t\nV 1 0 0 0\n").find("no 'F 3' format line"), std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3\n").find(":7: surface line needs"), std::string::npos);
  EXPECT_EQ(load_error(header + "S 1 1 2 3 4 0 0 0.9 sq\nE\nanything after the end\n"), "");
  EXPECT_EQ(load_error(header + "S 1 1 2 3 0 0 0 0.9 tri ! a triangle\n"), "");
}
