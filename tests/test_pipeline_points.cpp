// The solve's output points (src/pipeline/solve.cpp split_output_points and the vertex gather):
// faces meeting at less than the crease angle share a point with a smoothed normal, sharper
// creases and material changes split, OBJ smoothing groups win over the angle, OBJ vn win over
// both and give the point its normal.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
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

// The unit cube [0,1]³ (builders::unit_cube: inward faces, ρ = 0.5, E = 1) as OBJ text, with
// the vn that `vn_at(corner position, face's inward normal)` gives each corner (none when it
// returns zero).
template <class VertexNormal>
std::string cube_obj(VertexNormal vn_at) {
  const Scene cube = builders::unit_cube();
  std::string obj = "mtllib cube.mtl\nusemtl wall\n", faces;
  for (const Vec3& v : cube.vertices)
    obj.append("v ")
        .append(std::to_string(v.x()))
        .append(" ")
        .append(std::to_string(v.y()))
        .append(" ")
        .append(std::to_string(v.z()) + "\n");
  int normals = 0;
  for (int f = 0; f < 6; ++f) {
    const Vec3 inward = newell_vector(cube.face_polygon(f)).normalized();
    faces += "f";
    for (int v : cube.faces[size_t(f)].vertices) {
      const Vec3 n = vn_at(cube.vertices[size_t(v)], inward);
      faces.append(" ").append(std::to_string(v + 1));
      if (n.isZero(0.0)) continue;
      char line[128];
      std::snprintf(line, sizeof line, "vn %.17g %.17g %.17g\n", n.x(), n.y(), n.z());
      obj += line;
      faces.append("//").append(std::to_string(++normals));
    }
    faces += "\n";
  }
  return obj + faces;
}

Scene load_cube(const std::string& obj, bool flip = false) {
  const std::filesystem::path dir = test_scratch::process_dir("photometria_points_");
  std::ofstream(dir / "cube.mtl") << "newmtl wall\nKd 0.5 0.5 0.5\nKe 1 1 1\n";
  std::ofstream(dir / "cube.obj") << obj;
  LoadOptions o;
  o.flip_normals = flip;
  return load_scene((dir / "cube.obj").string(), o);
}

double worst_relative_error(const SolveResult& r, double exact) {
  double worst = 0.0;
  for (int o = 0; o < static_cast<int>(r.points.size()); ++o)
    worst = std::max(worst, std::abs(r.point_radiosity(o, 0) - exact) / exact);
  return worst;
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

// OBJ vn win over the crease angle both ways. A cube whose corners each give one vn for all
// three faces (along the diagonal, into the cube) has 8 points although its faces meet at 90°,
// at crease angle 30 as at 0, each with that vn as its normal; and since those points' own
// patches rise above their horizon (a concave corner), the uniformly emitting cube stays exact
// (B = E / (1 − ρ) = 2) only if the own-patch gap follows the file's normal. A cube whose vn are
// its faces' own normals (flat shading) keeps 24 points even at 100°, where the angle alone
// joins each corner. vn pointing into the faces' backs are not used (the angle decides);
// --flip-normals turns faces and vn together, so the flipped cube's vn are used again.
TEST(OutputPoints, VertexNormalsWinOverTheAngle) {
  const Vec3 centre(0.5, 0.5, 0.5);
  const auto diagonal_in = [&](const Vec3& p, const Vec3&) { return Vec3((centre - p).normalized()); };
  const auto diagonal_out = [&](const Vec3& p, const Vec3&) { return Vec3((p - centre).normalized()); };
  const auto flat = [](const Vec3&, const Vec3& inward) { return inward; };

  const Scene shared = load_cube(cube_obj(diagonal_in));
  for (const double crease : {0.0, 30.0}) {
    SCOPED_TRACE(crease);
    const SolveResult r = solve_whole_faces(shared, crease);
    ASSERT_EQ(r.points.size(), 8u);
    for (const OutputPoint& p : r.points) EXPECT_NEAR((p.normal - (centre - p.position).normalized()).norm(), 0, 1e-12);
    EXPECT_LT(worst_relative_error(r, 2.0), 1e-7);
  }
  const Scene flat_cube = load_cube(cube_obj(flat));
  EXPECT_EQ(solve_whole_faces(flat_cube, 100.0).points.size(), 24u);
  EXPECT_EQ(solve_whole_faces(builders::unit_cube(), 100.0).points.size(), 8u);  // without vn: joined

  // Into the back of every face: not used, so at 30° the corners stay split as without vn.
  const SolveResult backwards = solve_whole_faces(load_cube(cube_obj(diagonal_out)), 30.0);
  EXPECT_EQ(backwards.points.size(), 24u);
  EXPECT_LT(worst_relative_error(backwards, 2.0), 1e-7);

  // Flipped: the faces point out, the vn with them; they are used (8 points, normals out). The
  // cube emits into nothing: B = E = 1. The outward vn of the other file now point in: unused.
  const SolveResult flipped = solve_whole_faces(load_cube(cube_obj(diagonal_in), true), 30.0);
  ASSERT_EQ(flipped.points.size(), 8u);
  for (const OutputPoint& p : flipped.points)
    EXPECT_NEAR((p.normal - (p.position - centre).normalized()).norm(), 0, 1e-12);
  EXPECT_LT(worst_relative_error(flipped, 1.0), 1e-12);
  EXPECT_EQ(solve_whole_faces(load_cube(cube_obj(diagonal_out), true), 30.0).points.size(), 24u);
}

// A uniformly emitting tessellated sphere whose corners carry vn: the sphere's own (inward
// radial) normals. The 15° creases are joined as by the angle, each point takes its vn as the
// normal, and every point stays exact (B = 2). With the vn of the faces in y < 0 turned by 1°
// about z, the two meridians where they meet the others (φ = 0° and 180°, 11 vertices each
// between the poles) are split although the angle would join them; the poles stay one point
// (their vn is the z axis, which the turn keeps).
TEST(OutputPoints, VertexNormalsSplitASeamTheAngleWouldJoin) {
  const double rho = 0.5;
  Scene sphere = validation::sphere_cap_scene(12, rho);
  for (Face& f : sphere.faces) f.material = 0;
  sphere.materials[0].emission = Rgb::Constant(1.0);
  const size_t joined = 2 + 11 * 24;
  EXPECT_EQ(solve_whole_faces(sphere, 30.0).points.size(), joined);  // without vn
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(M_PI / 180, Vec3::UnitZ()).toRotationMatrix();
  for (const bool seam : {false, true}) {
    SCOPED_TRACE(seam ? "seam" : "no seam");
    Scene s = sphere;
    for (int f = 0; f < static_cast<int>(s.faces.size()); ++f) {
      Face& face = s.faces[size_t(f)];
      Vec3 centroid = Vec3::Zero();
      for (int v : face.vertices) centroid += s.vertices[size_t(v)] / double(face.vertices.size());
      for (int v : face.vertices) {
        const Vec3 radial = -s.vertices[size_t(v)].normalized();
        face.corner_normals.push_back(seam && centroid.y() < 0 ? Vec3(turn * radial) : radial);
      }
    }
    const SolveResult r = solve_whole_faces(s, 30.0);
    EXPECT_EQ(r.points.size(), joined + (seam ? 22 : 0));
    int turned = 0;
    for (int o = 0; o < static_cast<int>(r.points.size()); ++o) {
      const OutputPoint& p = r.points[size_t(o)];
      const Vec3 radial = -p.position.normalized();
      // A turned point is one whose own faces lie in y < 0: its normal is their (turned) vn.
      if ((p.normal - radial).norm() > 1e-12) {
        EXPECT_NEAR((p.normal - turn * radial).norm(), 0.0, 1e-12) << p.position.transpose();
        ++turned;
      }
      ASSERT_TRUE(std::isfinite(r.point_radiosity(o, 0)));
    }
    // Without the seam: every point radial (exact), and exact B. With it: the y < 0 half's points
    // except the poles are turned (11 rings × 13 meridians, φ = 180° to 360° inclusive). The
    // split seam points are then ~2e-3 off (printed), as the points of a seam split by smoothing
    // groups are: a split point sees the other cluster's patches at its position as sources.
    EXPECT_EQ(turned, seam ? 11 * 13 : 0);
    if (!seam) {
      EXPECT_LT(worst_relative_error(r, 2.0), 1e-7);
    } else {
      std::printf("uniform sphere, vn turned 1 degree on one half: worst relative error %.3e\n",
                  worst_relative_error(r, 2.0));
    }
  }
}

// Patch corners along a face's edges and inside it take the face's corner vn interpolated
// (linear along an edge, so both faces of an edge agree there). Two squares hinged at 10°,
// each cut into 2 × 2 patches, above an emitting square: along the hinge (3 positions: its
// ends and its middle) the points are joined at 30° without vn; with each face's own normal as
// its vn (flat) they are split everywhere along it, also when a third square without vn, 5°
// from either, hinges there; with the halfway normal at both hinge
// corners of both faces they are joined, the middle too, with that normal, and the floor
// square's centre takes the mean of its corners' vn.
TEST(OutputPoints, VertexNormalsAreInterpolatedAlongEdgesAndInsideFaces) {
  const double t = 10 * M_PI / 180;
  const Vec3 floor_n(0, 0, 1), tilted_n(-std::sin(t), 0, std::cos(t)), halfway(-std::sin(t / 2), 0, std::cos(t / 2));
  auto vn_line = [](const Vec3& n) {
    char line[128];
    std::snprintf(line, sizeof line, "vn %.17g %.17g %.17g\n", n.x(), n.y(), n.z());
    return std::string(line);
  };
  auto hinge = [&](const std::string& floor_face, const std::string& tilted_face, const std::string& more = "") {
    char tilted[128];
    std::snprintf(tilted, sizeof tilted, "v %.17g 0 %.17g\nv %.17g 1 %.17g\n", 1 + std::cos(t), std::sin(t),
                  1 + std::cos(t), std::sin(t));
    std::string s = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
    s += tilted;
    s += "v -1 -1 3\nv -1 3 3\nv 4 3 3\nv 4 -1 3\n";
    s += vn_line(floor_n) + vn_line(tilted_n) + vn_line(halfway);
    s += "mtllib hinge_vn.mtl\nusemtl grey\n" + floor_face + "\n" + tilted_face + "\n" + more;
    s += "usemtl lamp\nf 7 8 9 10\n";
    return s;
  };
  const std::filesystem::path dir = test_scratch::process_dir("photometria_points_");
  std::ofstream(dir / "hinge_vn.mtl") << "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe 1 1 1\n";
  SolveOptions opt;
  opt.patching.max_edge = 0.5;
  opt.crease_angle_degrees = 30.0;
  // The points on the hinge line x = 1, z = 0, by y.
  auto on_hinge = [](const SolveResult& r) {
    std::map<double, std::vector<Vec3>> normals;
    for (const OutputPoint& p : r.points)
      if (std::abs(p.position.x() - 1) < 1e-12 && std::abs(p.position.z()) < 1e-12)
        normals[std::round(2 * p.position.y()) / 2].push_back(p.normal);
    return normals;
  };
  const auto plain = on_hinge(solve_scene(load_obj_text("hinge_vn.obj", hinge("f 1 2 3 4", "f 2 5 6 3")), opt));
  const SolveResult flat_r =
      solve_scene(load_obj_text("hinge_vn.obj", hinge("f 1//1 2//1 3//1 4//1", "f 2//2 5//2 6//2 3//2")), opt);
  const SolveResult shared_r =
      solve_scene(load_obj_text("hinge_vn.obj", hinge("f 1//1 2//3 3//3 4//1", "f 2//3 5//2 6//2 3//3")), opt);
  // A third square on the hinge, halfway up (5° from either) and without vn: it joins one side
  // by the angle, but cannot bring the two sides' different vn into one point.
  char middle[160];
  std::snprintf(middle, sizeof middle, "v %.17g 0 %.17g\nv %.17g 1 %.17g\nf 2 11 12 3\n", 1 + std::cos(t / 2),
                std::sin(t / 2), 1 + std::cos(t / 2), std::sin(t / 2));
  const auto three = on_hinge(
      solve_scene(load_obj_text("hinge_vn.obj", hinge("f 1//1 2//1 3//1 4//1", "f 2//2 5//2 6//2 3//2", middle)), opt));
  const auto flat = on_hinge(flat_r), shared = on_hinge(shared_r);
  ASSERT_EQ(three.size(), 3u);
  ASSERT_EQ(plain.size(), 3u);
  ASSERT_EQ(flat.size(), 3u);
  ASSERT_EQ(shared.size(), 3u);
  for (const double y : {0.0, 0.5, 1.0}) {
    SCOPED_TRACE(y);
    EXPECT_EQ(plain.at(y).size(), 1u);
    ASSERT_EQ(flat.at(y).size(), 2u);
    for (const Vec3& n : flat.at(y))
      EXPECT_LT(std::min((n - floor_n).norm(), (n - tilted_n).norm()), 1e-12) << n.transpose();
    EXPECT_EQ(three.at(y).size(), 2u);
    ASSERT_EQ(shared.at(y).size(), 1u);
    EXPECT_NEAR((shared.at(y)[0] - halfway).norm(), 0.0, 1e-12);
  }
  // The floor square's centre: equal weights on its corners' vn (two floor_n, two halfway).
  int centres = 0;
  for (const OutputPoint& p : shared_r.points)
    if ((p.position - Vec3(0.5, 0.5, 0)).norm() < 1e-12) {
      EXPECT_NEAR((p.normal - (floor_n + halfway).normalized()).norm(), 0.0, 1e-12);
      ++centres;
    }
  EXPECT_EQ(centres, 1);
  for (int o = 0; o < static_cast<int>(shared_r.points.size()); ++o)
    ASSERT_TRUE(std::isfinite(shared_r.point_radiosity(o, 0)));
}
