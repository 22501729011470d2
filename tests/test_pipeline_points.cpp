// The solve's output points (src/pipeline/solve.cpp split_output_points and the vertex gather):
// faces meeting at less than the crease angle share a point with a smoothed normal, sharper
// creases and material changes split, OBJ smoothing groups win over the angle.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "pipeline/solve.h"
#include "scene/scene.h"
#include "scene_builders.h"
#include "scratch_dir.h"
#include "validation/scenes.h"

using namespace photometria;

namespace {

SolveResult solve_whole_faces(const Scene& scene, double crease_angle) {
  SolveOptions opt;
  opt.patching.max_edge = 0.0;  // every face one patch: the point counts below are exact
  opt.crease_angle_degrees = crease_angle;
  return solve_scene(scene, opt);
}

// RMS and max relative error of the point radiosity against the sphere's exact value
// B(x) = E(x) + ρ Ē / (1 − ρ) (every point of a sphere sees any region in proportion to its
// area; Ē = 1/4, the emitting cap z >= 1/2 of the true sphere).
struct PointErrors {
  double rms = 0.0, max = 0.0;
};
PointErrors sphere_point_errors(const SolveResult& r, const Scene& scene, double rho) {
  PointErrors e;
  for (int o = 0; o < static_cast<int>(r.points.size()); ++o) {
    const double emission = scene.materials[size_t(r.points[size_t(o)].material)].emission[0];
    const double exact = emission + rho * 0.25 / (1.0 - rho);
    const double err = std::abs(r.point_radiosity(o, 0) - exact) / exact;
    e.rms += err * err;
    e.max = std::max(e.max, err);
  }
  e.rms = std::sqrt(e.rms / double(r.points.size()));
  return e;
}

Scene load_obj_text(const std::string& name, const std::string& text) {
  const std::filesystem::path path = test_scratch::process_dir("photometria_points_") / name;
  std::ofstream(path) << text;
  return load_scene(path.string());
}

}  // namespace

// A tessellated sphere (12 rings, 24 longitudes: 15° between neighbouring faces): with the default
// crease angle every vertex is one point (the ring where the emitting cap begins two: a material
// change), and the smoothed normals, close to the sphere's, give smaller point errors than the
// facets' own normals.
TEST(OutputPoints, SphereSharesVerticesAndErrsLessWithTheCreaseAngle) {
  const double rho = 0.5;
  const Scene sphere = validation::sphere_cap_scene(12, rho);
  const SolveResult sharp = solve_whole_faces(sphere, 0.0), smooth = solve_whole_faces(sphere, 30.0);
  // Corners: 2 × 24 pole triangles (3 each) and 10 × 24 quads (4 each).
  EXPECT_EQ(sharp.points.size(), 2u * 24 * 3 + 10u * 24 * 4);
  // Vertices: 2 poles and 11 rings of 24, the cap's edge ring (z = 1/2) twice.
  EXPECT_EQ(smooth.points.size(), 2u + 11 * 24 + 24);
  const PointErrors e_sharp = sphere_point_errors(sharp, sphere, rho),
                    e_smooth = sphere_point_errors(smooth, sphere, rho);
  std::printf("point errors: crease 0: rms %.3e max %.3e; crease 30: rms %.3e max %.3e\n", e_sharp.rms, e_sharp.max,
              e_smooth.rms, e_smooth.max);
  EXPECT_LT(e_smooth.rms, e_sharp.rms);
  EXPECT_LT(e_smooth.max, e_sharp.max);
  // A smoothed normal is the sphere's own (inward radial) to within a fraction of the 15° facets,
  // except on the cap's edge ring, where each side's point averages its own band only (7.5° off).
  for (const OutputPoint& p : smooth.points) {
    const double off = std::acos(std::min(1.0, p.normal.dot(-p.position.normalized()))) * 180 / M_PI;
    if (std::abs(p.position.z() - 0.5) < 1e-9) EXPECT_NEAR(off, 7.5, 0.5);
    else EXPECT_LT(off, 1.0);
  }
  for (int o = 0; o < static_cast<int>(smooth.points.size()); ++o)
    ASSERT_TRUE(std::isfinite(smooth.point_radiosity(o, 0)));
}

// A cube keeps its sharp edges at 30° (its faces meet at 90°): 8 corners × 3 faces, as at 0°.
TEST(OutputPoints, CubeKeepsItsCorners) {
  const Scene cube = builders::unit_cube();
  EXPECT_EQ(solve_whole_faces(cube, 30.0).points.size(), 24u);
  EXPECT_EQ(solve_whole_faces(cube, 0.0).points.size(), 24u);
  // At 100°, the faces of each corner join: one point per corner with the diagonal normal.
  const SolveResult blunt = solve_whole_faces(cube, 100.0);
  ASSERT_EQ(blunt.points.size(), 8u);
  for (const OutputPoint& p : blunt.points)
    EXPECT_NEAR(std::abs(p.normal.x()) + std::abs(p.normal.y()) + std::abs(p.normal.z()), std::sqrt(3.0), 1e-12);
}

// Two faces hinged along one edge: joined or split by the angle, by smoothing groups when the
// file gives them (s 1 / s 2 / s off), and never across a material change.
TEST(OutputPoints, SmoothingGroupsWinOverTheAngle) {
  // A floor square and a square tilted up by `tilt` degrees along the edge x = 1, both facing +z
  // (more or less), above a large emitting square facing down, so that something is solved.
  auto hinge = [](double tilt, const std::string& groups_a, const std::string& groups_b, const std::string& mtl_b) {
    const double t = tilt * M_PI / 180;
    std::string s = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
    s += "v " + std::to_string(1 + std::cos(t)) + " 0 " + std::to_string(std::sin(t)) + "\n";
    s += "v " + std::to_string(1 + std::cos(t)) + " 1 " + std::to_string(std::sin(t)) + "\n";
    s += "v -1 -1 3\nv -1 3 3\nv 4 3 3\nv 4 -1 3\n";
    s += "mtllib hinge.mtl\nusemtl grey\n" + groups_a + "f 1 2 3 4\n" + mtl_b + groups_b + "f 2 5 6 3\n";
    s += "usemtl lamp\ns off\nf 7 8 9 10\n";
    return s;
  };
  const std::filesystem::path dir = test_scratch::process_dir("photometria_points_");
  std::ofstream(dir / "hinge.mtl")
      << "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl grey2\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe 1 1 1\n";
  // Points: 4 + 4 + 4 for three separate quads; the shared edge's 2 vertices joined save 2.
  auto points = [&](const std::string& obj, double crease) {
    return solve_whole_faces(load_obj_text("hinge.obj", obj), crease).points.size();
  };
  EXPECT_EQ(points(hinge(10, "", "", ""), 30.0), 10u);                // 10° < 30°: joined
  EXPECT_EQ(points(hinge(10, "", "", ""), 0.0), 12u);                 // 0: every crease sharp
  EXPECT_EQ(points(hinge(60, "", "", ""), 30.0), 12u);                // 60° > 30°: split
  EXPECT_EQ(points(hinge(10, "s 1\n", "s 2\n", ""), 30.0), 12u);      // different groups: split
  EXPECT_EQ(points(hinge(10, "s 1\n", "s off\n", ""), 30.0), 12u);    // s off: split
  EXPECT_EQ(points(hinge(60, "s 3\n", "", ""), 30.0), 10u);           // one group (s 3 holds on): joined
  EXPECT_EQ(points(hinge(10, "", "", "usemtl grey2\n"), 30.0), 12u);  // another material: split
  // Joined at 10°: the shared points' normal halfway between the two faces' (equal corner angles).
  const SolveResult joined = solve_whole_faces(load_obj_text("hinge.obj", hinge(10, "", "", "")), 30.0);
  int halfway = 0;
  for (const OutputPoint& p : joined.points)
    if (std::abs(p.position.x() - 1) < 1e-12 && std::abs(p.position.z()) < 1e-12) {
      EXPECT_NEAR(p.normal.dot(Eigen::Vector3d(-std::sin(5 * M_PI / 180), 0, std::cos(5 * M_PI / 180))), 1.0, 1e-12);
      ++halfway;
    }
  EXPECT_EQ(halfway, 2);
}

// A uniformly emitting tessellated sphere: B = E / (1 − ρ) = 2 at every point, exactly, with
// sharp and with smoothed points. A smoothed point's own patches rise above its horizon (the
// surface is concave): the gap below them takes their radiosity, or the sum would fall short.
TEST(OutputPoints, UniformSphereStaysExactWithSmoothedNormals) {
  const double rho = 0.5;
  Scene sphere = validation::sphere_cap_scene(12, rho);
  for (Face& f : sphere.faces) f.material = 0;  // one material: no split at the cap's edge
  sphere.materials[0].emission = Rgb::Constant(1.0);
  for (const double crease : {0.0, 30.0}) {
    const SolveResult r = solve_whole_faces(sphere, crease);
    double worst = 0.0;
    for (int o = 0; o < static_cast<int>(r.points.size()); ++o)
      worst = std::max(worst, std::abs(r.point_radiosity(o, 0) - 2.0) / 2.0);
    EXPECT_LT(worst, 1e-7) << "crease angle " << crease;
  }
}
