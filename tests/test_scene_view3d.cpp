// View3D .vs3 input: the manual's cube, an obstruction-only surface, F 3a, combined surfaces,
// subsurfaces, null and mask surfaces, refused parts named by line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "patching/patching.h"
#include "rectangle_reference.h"
#include "scene/scene.h"
#include "scratch_dir.h"
#include "util/error.h"
#include "viewfactors/job.h"
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

// Repeated surface names stay separate surfaces: "#<surface number>" is appended, then "#" until
// the name is free (here surface 4's "a#4" is surface 3's name, so surface 4 becomes "a#4#").
TEST(View3dInput, RepeatedSurfaceNamesBecomeSeparateGroups) {
  std::ifstream in(data + "view3d_cube.vs3");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& [from, to] : {std::pair{"floor", "a"}, {"ceiling", "a"}, {"south", "a#4"}, {"east", "a"}})
    text.replace(text.find(from), std::string(from).size(), to);
  const Scene s = load_scene(write_temp("names.vs3", text));
  ASSERT_EQ(s.faces.size(), 6u);
  EXPECT_EQ(s.groups, (std::vector<std::string>{"a", "a#2", "a#4", "a#4#", "north", "west"}));
  for (int f = 0; f < 6; ++f) EXPECT_EQ(s.faces[size_t(f)].group, f);
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
  EXPECT_NE(load_error(header + "M 1 1 2 3 4 0 0 0.9 m\n").find("bad.vs3:7: mask surface 1 needs a base"),
            std::string::npos);
  EXPECT_NE(load_error(header + "N 1 1 2 3 4 0 0 0.9 m\n").find(":7: null surface 1 needs a base"), std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3 4 2 0 0.9 a\n").find(":7: base surface 2 must be an earlier surface"),
            std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3 4 0 1 0.9 a\n").find(":7: combined surface (cmbn = 1) must name an earlier"),
            std::string::npos);
  EXPECT_NE(load_error("T t\nF 2\n").find("bad.vs3:2: unsupported geometry format '2'"), std::string::npos);
  EXPECT_NE(load_error("C eps=1e-4 foo=3\nF 3\n").find(":1: unsupported control key 'foo'"), std::string::npos);
  EXPECT_NE(load_error(header + "X 1\n").find(":7: unknown View3D record 'X'"), std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3 9 0 0 0.9 a\n").find(":7: vertex 9 not defined"), std::string::npos);
  EXPECT_NE(load_error("F 3\nV 2 0 0 0\n").find(":2: vertex number 2 out of sequence"), std::string::npos);
  EXPECT_NE(load_error("T t\nV 1 0 0 0\n").find("no 'F 3' or 'F 3a' format line"), std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3\n").find(":7: surface line needs"), std::string::npos);
  EXPECT_EQ(load_error(header + "S 1 1 2 3 4 0 0 0.9 sq\nE\nanything after the end\n"), "");
  EXPECT_EQ(load_error(header + "S 1 1 2 3 0 0 0 0.9 tri ! a triangle\n"), "");
}

namespace {

// Vertices of face f of s, in order.
std::vector<Vec3> corners(const Scene& s, size_t f) {
  std::vector<Vec3> out;
  for (int v : s.faces[f].vertices) out.push_back(s.vertices[static_cast<size_t>(v)]);
  return out;
}

// True when b is a cyclic rotation of a (same polygon, same facing), every vertex within tol.
bool same_polygon(const std::vector<Vec3>& a, const std::vector<Vec3>& b, double tol) {
  if (a.size() != b.size()) return false;
  for (size_t r = 0; r < b.size(); ++r) {
    bool all = true;
    for (size_t k = 0; k < a.size() && all; ++k) all = (a[k] - b[(k + r) % b.size()]).norm() <= tol;
    if (all) return true;
  }
  return false;
}

}  // namespace

TEST(View3dInput, BlastFormatPlacesRectanglesAndTrianglesByAzimuthAndTilt) {
  // R: origin (1, 2, 0.5), azimuth 90 (facing east), tilt 60, width 2, height 1. Plane axes
  // u = (−cos 90°, sin 90°, 0) = (0, 1, 0) and v = (−cos 60° sin 90°, −cos 60° cos 90°, sin 60°)
  // = (−0.5, 0, √3/2); corners origin + x u + y v for (0,0) (2,0) (2,1) (0,1):
  // (1, 2, 0.5), (1, 4, 0.5), (0.5, 4, 0.5 + √3/2), (0.5, 2, 0.5 + √3/2); front normal
  // u × v = (sin 60°, 0, cos 60°).
  // T: origin (0, 0, −1), azimuth 180, tilt 0 (a floor facing up): u = (1, 0, 0), v = (0, 1, 0),
  // so its points (0,0) (3,0) (0,2) are (0, 0, −1), (3, 0, −1), (0, 2, −1); normal +z.
  // Q: origin (0, 0, 4), azimuth 0, tilt 180 (a ceiling facing down): u = (−1, 0, 0),
  // v = (0, 1, 0); points (0,0) (1,0) (1,1) (0,1) are (0,0,4) (−1,0,4) (−1,1,4) (0,1,4); normal −z.
  const double h = std::sqrt(3.0) / 2.0;
  const Scene s = load_scene(write_temp("blast.vs3",
                                        "T blast\nC encl=0\nf 3A\n"
                                        "S 1 r 0 0 0.8 slope ! comment\n  1 2 0.5  90 60\n 2 1\n"
                                        "S 2 T 0 0 0.7 tri\n0 0 -1 180 0  0 0  3 0  0 2\n"
                                        "/ a slash comment\n"
                                        "S 3 Q 0 0 0.6\n0 0 4 0 180\n0 0 1 0 1 1 0 1\n"
                                        "O 4 R\n 5 5 5 0 90 1 1\n*\n"));
  ASSERT_EQ(s.faces.size(), 4u);
  EXPECT_TRUE(same_polygon(corners(s, 0),
                           {Vec3(1, 2, 0.5), Vec3(1, 4, 0.5), Vec3(0.5, 4, 0.5 + h), Vec3(0.5, 2, 0.5 + h)}, 1e-12));
  EXPECT_TRUE((polygon_normal(s.face_polygon(0)) - Vec3(h, 0, 0.5)).norm() < 1e-12);
  EXPECT_TRUE(same_polygon(corners(s, 1), {Vec3(0, 0, -1), Vec3(3, 0, -1), Vec3(0, 2, -1)}, 1e-12));
  EXPECT_GT(polygon_normal(s.face_polygon(1)).z(), 0.999);
  EXPECT_TRUE(same_polygon(corners(s, 2), {Vec3(0, 0, 4), Vec3(-1, 0, 4), Vec3(-1, 1, 4), Vec3(0, 1, 4)}, 1e-12));
  EXPECT_LT(polygon_normal(s.face_polygon(2)).z(), -0.999);
  EXPECT_TRUE(s.faces[3].obstruction_only);
  EXPECT_EQ(s.groups[s.faces[0].group], "slope");
  EXPECT_EQ(s.groups[s.faces[2].group], "S3");
  EXPECT_EQ(view3d_emissivities(write_temp("blast.vs3",
                                           "F 3a\nS 1 T 0 0 0.7 t\n0 0 0 0 0 0 0 1 0 0 1\n"
                                           "O 2 T\n0 0 1 0 0 0 0 1 0 0 1\n")),
            (std::vector<double>{0.7, 0.0}));
}

TEST(View3dInput, BlastAndGeneralFormatsOfTheManualsLShapedRoomAreTheSameSurfaces) {
  // The manual's Pinney & Bean test 4 in both formats (tests/data): surface by surface the same
  // polygon with the same facing, vertices within 1e-9, before combination (faces, not groups).
  const Scene a = load_scene(data + "view3d_pinney_bean_test_4.vs3");
  const Scene b = load_scene(data + "view3d_pinney_bean_test_4_f3a.vs3");
  ASSERT_EQ(a.faces.size(), 12u);
  ASSERT_EQ(b.faces.size(), 12u);
  for (size_t f = 0; f < 12; ++f) {
    EXPECT_TRUE(same_polygon(corners(a, f), corners(b, f), 1e-9)) << "surface " << f + 1;
    EXPECT_NEAR(polygon_area(a.face_polygon(static_cast<int>(f))), polygon_area(b.face_polygon(static_cast<int>(f))),
                1e-9);
    EXPECT_EQ(a.faces[f].group, b.faces[f].group);
  }
}

TEST(View3dInput, CombinedSurfacesJoinTheGroupOfTheSurfaceTheyCombineInto) {
  const Scene s = load_scene(data + "view3d_pinney_bean_test_4.vs3");
  ASSERT_EQ(s.groups.size(), 8u);  // 12 surfaces, 9 and 10 into 7, 11 and 12 into 8
  EXPECT_EQ(s.groups[s.faces[8].group], "srf-7");
  EXPECT_EQ(s.faces[9].group, s.faces[6].group);
  EXPECT_EQ(s.faces[10].group, s.faces[7].group);
  EXPECT_EQ(s.faces[11].group, s.faces[7].group);
  EXPECT_NE(load_error(header + "S 1 1 2 3 4 0 0 0.9 a\nS 2 1 2 3 4 0 1 0.9 b\nS 3 1 2 3 4 0 2 0.9 c\n")
                .find(":9: combined surface (cmbn = 2) names a surface itself combined into 1"),
            std::string::npos);
  EXPECT_NE(load_error(header + "S 1 1 2 3 4 0 0 0.9 a\nO 2 1 2 3 4 0 1 0.9 b\n")
                .find(":8: combined surface (cmbn = 1) on an obstruction-only"),
            std::string::npos);
}

TEST(View3dInput, BlastFormatNullSurfaceIsTurnedToFaceAsItsBase) {
  // Wall: origin (0, 0, 0), azimuth 180, tilt 90: u = (1, 0, 0), v = (0, 0, 1), facing −y;
  // 3 × 2. Null: origin (2, 0, 0.5), azimuth 0: u = (−1, 0, 0), facing +y (toward the wall's
  // back, as View3D requires); 1 × 1, so x ∈ [1, 2], z ∈ [0.5, 1.5]: within the wall.
  const Scene s = load_scene(write_temp("blast_null.vs3",
                                        "F 3a\nS 1 R 0 0 0.9 wall\n0 0 0 180 90 3 2\n"
                                        "N 2 R 1 0 0.9 hole\n2 0 0.5 0 90 1 1\n"));
  ASSERT_EQ(s.faces.size(), 2u);
  EXPECT_TRUE(s.faces[1].null_surface);
  EXPECT_EQ(s.faces[1].base_group, s.faces[0].group);
  EXPECT_LT(polygon_normal(s.face_polygon(0)).y(), -0.999);
  EXPECT_LT(polygon_normal(s.face_polygon(1)).y(), -0.999);  // reversed to face as the wall
  EXPECT_TRUE(same_polygon(corners(s, 1), {Vec3(2, 0, 1.5), Vec3(1, 0, 1.5), Vec3(1, 0, 0.5), Vec3(2, 0, 0.5)}, 1e-12));
}

TEST(View3dInput, BlastFormatRefusesBadRecordsNamingTheLine) {
  const std::string f = "T t\nF 3a\n";
  EXPECT_NE(load_error(f + "S 1 X 0 0 0.9 a\n").find("bad.vs3:3: surface shape 'X' is not R"), std::string::npos);
  EXPECT_NE(load_error(f + "S 1 R 0 0\n").find(":3: surface line needs 'S n shape base cmbn emit name' (F 3a)"),
            std::string::npos);
  EXPECT_NE(load_error(f + "S 1 R 0 0 0.9 a\n 0 0 0 0 90 1\nS 2 R 0 0 0.9 b\n")
                .find(":3: surface 1 (shape R) needs 7 geometry numbers (x y z azimuth tilt width height) on the "
                      "lines after it; found 6 before line 5"),
            std::string::npos);
  EXPECT_NE(load_error(f + "S 1 T 0 0 0.9 a\n 0 0 0 0 90 0 0 1 0\n").find("found 9 before the end of the data"),
            std::string::npos);
  EXPECT_NE(load_error(f + "S 1 R 0 0 0.9 a\n 0 0 0 0 90 1 1 7\n").find(":4: more geometry numbers than surface 1"),
            std::string::npos);
  EXPECT_NE(load_error(f + "S 1 R 0 0 0.9 a\n 0 0 0 0 90 1 x\n").find(":4: geometry value 'x' is not a number"),
            std::string::npos);
  EXPECT_NE(load_error(f + "S 1 R 0 0 0.9 a\n 0 0 0 0 90 1 0\n").find(":3: rectangle 1 needs a positive width"),
            std::string::npos);
  EXPECT_NE(load_error(f + "V 1 0 0 0\n").find(":3: V records are not part of the F 3a format"), std::string::npos);
}

TEST(View3dInput, CombinedLShapedRoomAgreesWithView3D) {
  // View3D 4.0.0 on the manual's Pinney & Bean test 4 (F 3 file) with the control line changed
  // to "C encl=0 list=0 eps=1.e-5 maxu=12 maxo=8" (no enclosure normalisation, no emissivities,
  // so geometric view factors), its output file after combining surfaces 9, 10 into 7 and 11, 12
  // into 8: 8 surfaces of areas 9 3 6 6 3 9 5 5, printed to 6 decimals. The F 3a file gives the
  // same table within 6e-6. The room is closed: our row sums are 1 within 3e-6, View3D's within
  // 4.5e-5 (rows 2 and 5), and its two entries farthest from ours, F(2→6) = F(5→1) (−5.0e-5) and
  // F(1→5) = F(6→2) (−1.7e-5), are those rows' excess; every other entry agrees within 3.2e-6.
  // Pairs around the inner corner of the L are partly occluded: the default fixed rule gets them
  // to 3% (F(1→5) 0.0339), hence --occluded-accuracy here.
  const double view3d[8][8] = {{0.000000, 0.113154, 0.378093, 0.027473, 0.032907, 0.182357, 0.133017, 0.133017},
                               {0.339463, 0.000000, 0.318997, 0.000000, 0.000000, 0.098721, 0.121432, 0.121432},
                               {0.567139, 0.159498, 0.000000, 0.000000, 0.000000, 0.041210, 0.116076, 0.116076},
                               {0.041210, 0.000000, 0.000000, 0.000000, 0.159498, 0.567139, 0.116076, 0.116076},
                               {0.098721, 0.000000, 0.000000, 0.318997, 0.000000, 0.339463, 0.121432, 0.121432},
                               {0.182357, 0.032907, 0.027473, 0.378093, 0.113154, 0.000000, 0.133017, 0.133017},
                               {0.239431, 0.072859, 0.139291, 0.139291, 0.072859, 0.239431, 0.000000, 0.096833},
                               {0.239431, 0.072859, 0.139291, 0.139291, 0.072859, 0.239431, 0.096833, 0.000000}};
  const double areas[8] = {9, 3, 6, 6, 3, 9, 5, 5};
  for (const char* file : {"view3d_pinney_bean_test_4.vs3", "view3d_pinney_bean_test_4_f3a.vs3"}) {
    SCOPED_TRACE(file);
    const Scene s = load_scene(data + file);
    ViewFactorOptions opt;
    opt.occluded_accuracy = 1e-6;
    const PatchViewFactors r = compute_view_factors(s, opt);
    const Aggregation agg = make_aggregation(s, r.mesh, AggregateLevel::Group);
    ASSERT_EQ(agg.size(), 8);
    EXPECT_EQ(agg.names[6], "srf-7");
    const ViewFactorMatrix F = aggregate(r.F, r.mesh, agg);
    for (int i = 0; i < 8; ++i) {
      EXPECT_NEAR(agg.areas[size_t(i)], areas[i], 1e-12);
      EXPECT_NEAR(F.row(i).sum(), 1.0, 5e-6) << i;
      for (int j = 0; j < 8; ++j) EXPECT_NEAR(F(i, j), view3d[i][j], 6e-5) << i << " " << j;
    }
  }
}

namespace {

// A 3 × 2 wall at z = 0 facing +z with a 1 × 1 window [1, 2] × [0.5, 1.5] (`window` is its line:
// an S subsurface of surface 1, or an N surface), and a 3 × 2 plate at z = 1 facing it.
std::string wall_with(const std::string& window) {
  return "T wall, window, plate\nF 3\n"
         "V 1 0 0 0\nV 2 3 0 0\nV 3 3 2 0\nV 4 0 2 0\n"
         "V 5 1 0.5 0\nV 6 2 0.5 0\nV 7 2 1.5 0\nV 8 1 1.5 0\n"
         "V 9 0 0 1\nV 10 0 2 1\nV 11 3 2 1\nV 12 3 0 1\n"
         "S 1 1 2 3 4 0 0 0.9 wall\n" +
         window + "\nS 3 9 10 11 12 0 0 0.7 plate\n";
}

ViewFactorMatrix group_factors(const Scene& s, Aggregation& agg, AggregateLevel level = AggregateLevel::Group) {
  const PatchViewFactors r = compute_view_factors(s, ViewFactorOptions{});
  agg = make_aggregation(s, r.mesh, level);
  return aggregate(r.F, r.mesh, agg);
}

}  // namespace

// View3D 4.0.0 on these three files (C encl=0 eps=1e-6) prints, rounded to 6 decimals, the
// values expected here: window 0.449330 0.606810 0.374442 0.101135; hole 0.449330 0.374442;
// mask 0.166667 0.374442, 1, 0.374442 (areas 5 1 6, 5 6 and 6 1 6).
TEST(View3dInput, SubsurfaceNullAndMaskSurfacesTakeTheirPartOutOfTheBase) {
  // A_w' F_w'p = A_w F_wp − A_s F_sp, A_w' = A_w − A_s (View3D manual, "Surface Types"; the
  // view-factor algebra of Modest 2013, ch. 4), each A F from the closed form of parallel
  // rectangles (tests/rectangle_reference.h).
  const double af_wp = double(rect_ref::parallel_af(0, 3, 0, 2, 0, 3, 0, 2, 1));
  const double af_sp = double(rect_ref::parallel_af(1, 2, 0.5, 1.5, 0, 3, 0, 2, 1));
  const Scene s = load_scene(write_temp("window.vs3", wall_with("S 2 5 6 7 8 1 0 0.8 window")));
  EXPECT_EQ(s.faces[1].base_group, s.faces[0].group);
  Aggregation agg;
  const ViewFactorMatrix F = group_factors(s, agg);
  ASSERT_EQ(agg.names, (std::vector<std::string>{"wall", "window", "plate"}));
  EXPECT_NEAR(agg.areas[0], 5.0, 1e-12);
  EXPECT_NEAR(agg.areas[1], 1.0, 1e-12);
  EXPECT_NEAR(F(0, 2), (af_wp - af_sp) / 5.0, 1e-9);
  EXPECT_NEAR(F(1, 2), af_sp, 1e-9);
  EXPECT_NEAR(F(2, 0), (af_wp - af_sp) / 6.0, 1e-9);
  EXPECT_NEAR(F(2, 1), af_sp / 6.0, 1e-9);
  EXPECT_NEAR(F(0, 1), 0.0, 1e-12);
  EXPECT_NEAR(F(1, 0), 0.0, 1e-12);
  EXPECT_NEAR(F(0, 0), 0.0, 1e-12);
  // A null surface removes that part of the base: the same wall row, no window row or column.
  const Scene n = load_scene(write_temp("hole.vs3", wall_with("N 2 8 7 6 5 1 0 0.8 hole")));
  EXPECT_TRUE(n.faces[1].null_surface);
  const ViewFactorMatrix G = group_factors(n, agg);
  ASSERT_EQ(agg.names, (std::vector<std::string>{"wall", "plate"}));
  EXPECT_NEAR(agg.areas[0], 5.0, 1e-12);
  EXPECT_NEAR(G(0, 1), (af_wp - af_sp) / 5.0, 1e-9);
  EXPECT_NEAR(G(1, 0), (af_wp - af_sp) / 6.0, 1e-9);
  EXPECT_NEAR(G(0, 0), 0.0, 1e-12);
  // A mask covers that part of the base, which then sees only the mask; the base keeps its area.
  const Scene m = load_scene(write_temp("mask.vs3", wall_with("M 2 8 7 6 5 1 0 0.8 mask")));
  EXPECT_TRUE(m.faces[1].mask_surface);
  const ViewFactorMatrix M = group_factors(m, agg);
  ASSERT_EQ(agg.names, (std::vector<std::string>{"wall", "mask", "plate"}));
  EXPECT_NEAR(agg.areas[0], 6.0, 1e-12);
  EXPECT_NEAR(agg.areas[1], 1.0, 1e-12);
  EXPECT_NEAR(M(0, 1), 1.0 / 6.0, 1e-12);
  EXPECT_NEAR(M(0, 2), (af_wp - af_sp) / 6.0, 1e-9);
  EXPECT_NEAR(M(1, 0), 1.0, 1e-12);
  EXPECT_NEAR(M(1, 2), 0.0, 1e-12);
  EXPECT_NEAR(M(2, 0), (af_wp - af_sp) / 6.0, 1e-9);
  EXPECT_NEAR(M(2, 1), 0.0, 1e-12);
}

// The same at --by face (one face per surface here): the base face is the base minus its
// subsurface, null or mask face, as at --by group, with the faces' names.
TEST(View3dInput, SubsurfacesTakeTheirPartOutOfTheBaseFaceToo) {
  for (const auto& [record, names] :
       {std::pair{std::string("S 2 5 6 7 8 1 0 0.8 window"), std::vector<std::string>{"face 0", "face 1", "face 2"}},
        {std::string("N 2 8 7 6 5 1 0 0.8 hole"), std::vector<std::string>{"face 0", "face 2"}},
        {std::string("M 2 8 7 6 5 1 0 0.8 mask"), std::vector<std::string>{"face 0", "face 1", "face 2"}}}) {
    const Scene s = load_scene(write_temp("sub.vs3", wall_with(record)));
    Aggregation by_group, by_face;
    const ViewFactorMatrix G = group_factors(s, by_group);
    const ViewFactorMatrix F = group_factors(s, by_face, AggregateLevel::Face);
    EXPECT_EQ(by_face.names, names) << record;
    EXPECT_EQ(by_face.areas, by_group.areas) << record;
    ASSERT_EQ(F.rows(), G.rows()) << record;
    EXPECT_LE((F - G).cwiseAbs().maxCoeff(), 1e-15) << record;
  }
}

// Rows subtracted from their base's cannot stream: --stream yes is refused naming why.
TEST(View3dInput, SubsurfacesAtTheFaceLevelAreNotStreamed) {
  const Scene s = load_scene(write_temp("window.vs3", wall_with("S 2 5 6 7 8 1 0 0.8 window")));
  ViewFactorOptions opt;
  opt.level = AggregateLevel::Face;
  opt.stream = RowStreaming::Yes;
  opt.row_sink_for = [](const PatchMesh&, const Aggregation&) {
    return std::function<bool(int, const double*)>([](int, const double*) { return true; });
  };
  try {
    compute_view_factors(s, opt);
    ADD_FAILURE() << "streamed rows that are subtracted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_EQ(std::string(e.what()),
              "--stream yes: subsurfaces are taken out of their base surfaces (their rows are "
              "subtracted)");
  }
}

// A combined base surface of two faces (the window names the right half, combined into the
// left): at --by face the window is taken out of the face that holds it.
TEST(View3dInput, SubsurfaceOfACombinedBaseLeavesTheOtherFaceWhole) {
  const std::string text =
      "T split wall, window, plate\nF 3\n"
      "V 1 0 0 0\nV 2 1.5 0 0\nV 3 1.5 2 0\nV 4 0 2 0\nV 5 3 0 0\nV 6 3 2 0\n"
      "V 7 1.75 0.5 0\nV 8 2.75 0.5 0\nV 9 2.75 1.5 0\nV 10 1.75 1.5 0\n"
      "V 11 0 0 1\nV 12 0 2 1\nV 13 3 2 1\nV 14 3 0 1\n"
      "S 1 1 2 3 4 0 0 0.9 left\nS 2 2 5 6 3 0 1 0.9 right\n"
      "S 3 7 8 9 10 2 0 0.8 window\nS 4 11 12 13 14 0 0 0.7 plate\n";
  const Scene s = load_scene(write_temp("combined.vs3", text));
  Aggregation agg;
  const ViewFactorMatrix F = group_factors(s, agg, AggregateLevel::Face);
  ASSERT_EQ(agg.names, (std::vector<std::string>{"face 0", "face 1", "face 2", "face 3"}));
  EXPECT_NEAR(agg.areas[0], 3.0, 1e-12);  // the left half, whole
  EXPECT_NEAR(agg.areas[1], 2.0, 1e-12);  // the right half without the window
  const double af_left = double(rect_ref::parallel_af(0, 1.5, 0, 2, 0, 3, 0, 2, 1));
  const double af_right = double(rect_ref::parallel_af(1.5, 3, 0, 2, 0, 3, 0, 2, 1));
  const double af_window = double(rect_ref::parallel_af(1.75, 2.75, 0.5, 1.5, 0, 3, 0, 2, 1));
  EXPECT_NEAR(F(0, 3), af_left / 3.0, 1e-9);
  EXPECT_NEAR(F(1, 3), (af_right - af_window) / 2.0, 1e-9);
  EXPECT_NEAR(F(2, 3), af_window, 1e-9);
}

TEST(View3dInput, SubsurfacesAreCheckedAsView3DDoes) {
  const auto error = [](const std::string& window) { return load_error(wall_with(window)); };
  EXPECT_NE(error("S 2 8 7 6 5 1 0 0.8 w").find("bad.vs3:16: subsurface of base surface 1 must face the same way"),
            std::string::npos);
  EXPECT_NE(error("M 2 5 6 7 8 1 0 0.8 w").find(":16: mask surface of base surface 1 must face opposite"),
            std::string::npos);
  EXPECT_NE(error("N 2 5 6 7 8 1 0 0.8 w").find(":16: null surface of base surface 1 must face opposite"),
            std::string::npos);
  EXPECT_NE(error("S 2 9 12 11 10 1 0 0.8 w").find(":16: subsurface of base surface 1 is not in the plane"),
            std::string::npos);
  EXPECT_NE(error("V 13 1 3 0\nS 2 5 6 7 13 1 0 0.8 w").find(":17: subsurface of base surface 1 is not within"),
            std::string::npos);
  EXPECT_NE(error("S 2 5 6 7 8 2 0 0.8 w").find(":16: base surface 2 must be an earlier surface"), std::string::npos);
  EXPECT_NE(error("N 2 8 7 6 5 0 0 0.8 w").find(":16: null surface 2 needs a base surface"), std::string::npos);
  EXPECT_NE(error("O 2 5 6 7 8 1 0 0.8 w").find(":16: an obstruction-only (O) surface cannot be a subsurface"),
            std::string::npos);
}

TEST(View3dInput, EveryControlKeyIsReportedAsHonouredOrIgnored) {
  const Scene s =
      load_scene(data + "view3d_pinney_bean_test_4.vs3");  // encl=1 list=2 eps=1.e-4 maxu=8 maxo=8 mino=0 emit=1
  ViewFactorJob job;
  const std::vector<std::string> notes = view3d_control_notes(s.settings["view3d"], job);
  ASSERT_EQ(notes.size(), 7u);
  EXPECT_EQ(notes[0], "eps=0.0001: superseded by --accuracy 1e-07");
  EXPECT_EQ(notes[1].rfind("maxu=8: ignored (View3D's own integration limits", 0), 0u);
  EXPECT_EQ(notes[4],
            "encl=1: not applied (rows are not normalised; use --enforce both for View3D's enclosure "
            "adjustment)");
  EXPECT_EQ(notes[5],
            "emit=1: honoured: Hottel's total exchange factors (script-F) with the surfaces' emissivities "
            "are written");
  EXPECT_EQ(notes[6].rfind("list=2: ignored", 0), 0u);
  job.enforcement = Enforcement::Both;
  EXPECT_EQ(view3d_control_notes(s.settings["view3d"], job)[4], "encl=1: honoured by --enforce both");
  EXPECT_EQ(view3d_control_notes(nlohmann::json{{"row", 3.0}}, job),
            (std::vector<std::string>{"row=3: ignored: every row and column is computed"}));
}

TEST(View3dInput, PointFactorsToABaseLeaveItsSubsurfaceOut) {
  // From a point on the plate facing the wall: F(point → wall') + F(point → window) is the factor
  // to the whole wall (the same window given as a surface of its own, base 0: the wall is whole),
  // and F(point → window) is positive.
  ViewFactorOptions opt;
  SurfacePoint p;
  p.position = Vec3(1.3, 0.9, 1.0);
  p.normal = -Vec3::UnitZ();
  const auto factors = [&](const std::string& window) {
    const Scene s = load_scene(write_temp("points.vs3", wall_with(window)));
    const PatchViewFactors r = compute_view_factors(s, opt);
    const Aggregation agg = make_aggregation(s, r.mesh, AggregateLevel::Group);
    return point_view_factors({p}, r.mesh, agg, r.visibility.get(), opt);
  };
  const ViewFactorMatrix with = factors("S 2 5 6 7 8 1 0 0.8 window");
  const ViewFactorMatrix without = factors("S 2 5 6 7 8 0 0 0.8 window");
  ASSERT_EQ(with.cols(), 3);
  ASSERT_EQ(without.cols(), 3);
  EXPECT_NEAR(with(0, 1), without(0, 1), 1e-12);
  EXPECT_GT(with(0, 1), 0.05);
  EXPECT_NEAR(with(0, 0) + with(0, 1), without(0, 0), 1e-9);
  EXPECT_NEAR(with(0, 2), 0.0, 1e-12);  // the plate itself
}
