// Clusters for hierarchical radiosity (src/hierarchical/clusters.h): the tree, its convexity,
// the transfer's bound against Lambert's exact factor, and whole solves with clusters against
// the same solves without.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <random>

#include "hierarchical/clusters.h"
#include "hierarchical/hierarchical.h"
#include "kernels/lambert.h"
#include "patching/patching.h"
#include "pipeline/solve.h"
#include "scene_builders.h"
#include "visibility/choice.h"

namespace pm = photometria;

namespace {

std::vector<pm::ClusterFace> faces_of(const pm::Scene& scene) {
  std::vector<pm::ClusterFace> out;
  for (int f = 0; f < int(scene.faces.size()); ++f) {
    const pm::Polygon p = scene.face_polygon(f);
    pm::ClusterFace c;
    c.corner_count = int(p.size());
    std::copy(p.begin(), p.end(), c.corners);
    c.normal = pm::polygon_normal(p);
    c.centroid = pm::polygon_centroid(p);
    c.area = pm::polygon_area(p);
    c.reflectance = 0.5;
    out.push_back(c);
  }
  return out;
}

// The top cluster's convexity, and whether some cluster below it is convex with more than one face.
std::pair<bool, bool> convexity(const pm::ClusterTree& t) {
  bool some = false;
  for (const pm::Cluster& c : t.clusters) some = some || (c.convex && c.count > 1);
  return {t.clusters.back().convex, some};
}

}  // namespace

TEST(ClusterTree, HoldsEveryFaceOnceWithChildrenBeforeParents) {
  pm::Scene s;
  builders::add_meshed_box(s, pm::Vec3(0, 0, 0), pm::Vec3(4, 3, 2.5), 5, true);
  builders::add_box(s, pm::Vec3(1, 1, 0.5), pm::Vec3(2, 2, 1));
  const std::vector<pm::ClusterFace> faces = faces_of(s);
  const pm::ClusterTree t = pm::build_cluster_tree(faces, 1e-9);
  const int n = int(faces.size());
  ASSERT_EQ(int(t.clusters.size()), n - 1);
  ASSERT_EQ(t.top(), pm::cluster_node(n - 2));
  EXPECT_EQ(t.clusters.back().count, n);
  std::vector<int> seen(size_t(n), 0);
  for (int k = 0; k < n; ++k) {
    ++seen[size_t(t.order[size_t(k)])];
    EXPECT_EQ(t.position[size_t(t.order[size_t(k)])], k);
  }
  for (int f = 0; f < n; ++f) EXPECT_EQ(seen[size_t(f)], 1) << "face " << f;
  for (int c = 0; c < n - 1; ++c) {
    const pm::Cluster& cl = t.clusters[size_t(c)];
    int count = 0, next = cl.first;
    double area = 0.0;
    for (const int child : cl.children) {
      // Each child is the next part of the range and lies before its parent.
      if (child >= 0) {
        EXPECT_EQ(t.parent[size_t(child)], c);
        EXPECT_EQ(t.position[size_t(child)], next);
        next += 1;
        count += 1;
      } else {
        const pm::Cluster& k = t.clusters[size_t(pm::cluster_of_node(child))];
        EXPECT_LT(pm::cluster_of_node(child), c);
        EXPECT_EQ(k.parent, c);
        EXPECT_EQ(k.first, next);
        next += k.count;
        count += k.count;
      }
      area += child >= 0 ? faces[size_t(child)].area : t.clusters[size_t(pm::cluster_of_node(child))].area;
    }
    EXPECT_EQ(count, cl.count);
    EXPECT_NEAR(area, cl.area, 1e-12 * cl.area);
    for (int k = cl.first; k < cl.first + cl.count; ++k) {
      const pm::ClusterFace& f = faces[size_t(t.order[size_t(k)])];
      for (int i = 0; i < f.corner_count; ++i) {
        EXPECT_TRUE(cl.box.contains(f.corners[i]));
        EXPECT_LE((f.corners[i] - cl.centre).norm(), cl.radius * (1 + 1e-12));
      }
    }
  }
  EXPECT_EQ(t.clusters.back().parent, -1);
}

// A solid box's faces (outward) are convex as a whole; a room's (inward) only wall by wall; a
// flat grid always; a convex solid of more than kMaxConvexPlanes face planes only in parts.
TEST(ClusterTree, ConvexWhereNoFaceLiesInFrontOfAnother) {
  pm::Scene solid, room, grid, prism;
  builders::add_meshed_box(solid, pm::Vec3(0, 0, 0), pm::Vec3(1, 2, 3), 3, false);
  builders::add_meshed_box(room, pm::Vec3(0, 0, 0), pm::Vec3(1, 2, 3), 3, true);
  builders::add_meshed_box(grid, pm::Vec3(0, 0, 0), pm::Vec3(1, 1, 1), 4, false);
  grid.faces.resize(16);  // the bottom side alone
  // A prism over a regular 40-gon (its 40 sides, outward): convex, with 40 planes.
  const int sides = 40;
  for (int k = 0; k < sides; ++k) {
    const double a0 = 2 * M_PI * k / sides, a1 = 2 * M_PI * (k + 1) / sides;
    const int b = int(prism.vertices.size());
    prism.vertices.emplace_back(std::cos(a0), std::sin(a0), 0);
    prism.vertices.emplace_back(std::cos(a1), std::sin(a1), 0);
    prism.vertices.emplace_back(std::cos(a1), std::sin(a1), 1);
    prism.vertices.emplace_back(std::cos(a0), std::sin(a0), 1);
    prism.faces.push_back({{b, b + 1, b + 2, b + 3}, 0, 0, k});
  }
  const double tol = 1e-9;
  EXPECT_EQ(convexity(pm::build_cluster_tree(faces_of(solid), tol)), std::make_pair(true, true));
  EXPECT_EQ(convexity(pm::build_cluster_tree(faces_of(room), tol)), std::make_pair(false, true));
  EXPECT_EQ(convexity(pm::build_cluster_tree(faces_of(grid), tol)), std::make_pair(true, true));
  EXPECT_EQ(convexity(pm::build_cluster_tree(faces_of(prism), tol)), std::make_pair(false, true));
  // A corner of the room: the floor's and a wall's faces together are not convex.
  pm::Scene corner = room;
  corner.faces.resize(18);  // bottom (9) and top (9): two parallel sides facing each other
  EXPECT_FALSE(pm::build_cluster_tree(faces_of(corner), tol).clusters.back().convex);
}

// For points of the receiving cluster, Lambert's exact factor from each face of the source
// cluster (all mutually visible) against the transfer at the point: within the estimate (scaled
// by the point's cosine toward the source), closer than the source taken as a point, and the
// estimate a small fraction of the factor when far apart. Sources flat (their faces in one plane) and curved (normals
// spread by up to 35°).
TEST(ClusterTransfer, EstimateHoldsAgainstLambertsExactFactor) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0, valid = 0;
  double worst = 0.0;        // largest |exact − transfer| / estimate
  double worst_point = 0.0;  // the same for B as a point (the expansion's zeroth order alone)
  for (int trial = 0; trial < 400; ++trial) {
    pm::Scene s;
    // Two clusters of 4 small quads each around (0,0,0) and (D,0,0), turned to each other.
    const double distance = 1.0 + 2.0 * (trial % 20);
    const bool flat = trial % 2 == 0;
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < 4; ++k) {
        const double lift = flat && side == 1 ? 0.0 : 0.3 * u(rng);
        const pm::Vec3 c(side * distance + lift, 0.3 * u(rng), 0.3 * u(rng));
        const double tilt = flat && side == 1 ? 0.0 : 0.7;
        pm::Vec3 n = pm::Vec3(side == 0 ? 1.0 : -1.0, tilt * u(rng), tilt * u(rng)).normalized();
        const pm::Vec3 a = n.unitOrthogonal() * 0.1, b = n.cross(a);
        const int v = int(s.vertices.size());
        for (const pm::Vec3& p : {pm::Vec3(c - a - b), pm::Vec3(c + a - b), pm::Vec3(c + a + b), pm::Vec3(c - a + b)})
          s.vertices.push_back(p);
        s.faces.push_back({{v, v + 1, v + 2, v + 3}, 0, 0, int(s.faces.size())});
      }
    const std::vector<pm::ClusterFace> faces = faces_of(s);
    const pm::ClusterTree t = pm::build_cluster_tree(faces, 1e-9);
    // The clusters holding faces 0..3 and 4..7: the top's children (the split is along x).
    const pm::Cluster& top = t.clusters.back();
    const int a = top.children[0], b = top.children[1];
    ASSERT_LT(a, 0);
    ASSERT_LT(b, 0);
    const int receiver = t.clusters[size_t(pm::cluster_of_node(a))].centre.x() < distance / 2 ? a : b;
    const int source = receiver == a ? b : a;
    const pm::ClusterTransfer tr = pm::cluster_transfer(t, faces, receiver, source);
    const double reach = pm::node_radius(t, faces, receiver) + pm::node_radius(t, faces, source);
    if (tr.distance <= 2 * reach) { EXPECT_FALSE(tr.valid); }
    if (!tr.valid) continue;
    ++valid;
    const pm::Cluster& rc = t.clusters[size_t(pm::cluster_of_node(receiver))];
    const pm::Cluster& sc = t.clusters[size_t(pm::cluster_of_node(source))];
    for (int k = rc.first; k < rc.first + rc.count; ++k) {
      const pm::ClusterFace& f = faces[size_t(t.order[size_t(k)])];
      for (int i = 0; i < f.corner_count; ++i) {
        const pm::Vec3 x = 0.7 * f.corners[i] + 0.3 * f.centroid;
        double exact = 0.0;
        for (int j = sc.first; j < sc.first + sc.count; ++j) {
          const pm::ClusterFace& q = faces[size_t(t.order[size_t(j)])];
          exact += pm::lambert_form_factor(pm::Receiver{x, f.normal}, q.corners, q.corner_count);
        }
        const double approx = pm::cluster_factor_at(x, f.normal, sc);
        const double cosine = f.normal.dot((sc.centre - x).normalized());
        EXPECT_LE(std::abs(exact - approx), tr.error * cosine) << "trial " << trial << " exact " << exact;
        worst = std::max(worst, std::abs(exact - approx) / (tr.error * cosine));
        const pm::Vec3 w = sc.centre - x;
        const double point = std::max(0.0, f.normal.dot(w)) * std::max(0.0, -sc.vector_area.dot(w)) /
                             (M_PI * w.squaredNorm() * w.squaredNorm());
        worst_point = std::max(worst_point, std::abs(exact - point) / (tr.error * cosine));
        ++checked;
      }
    }
    if (tr.distance > 30.0) { EXPECT_LT(tr.error, 0.02 * tr.factor) << "d " << tr.distance; }
  }
  std::printf("%d valid links, %d points: worst |exact - transfer| / estimate %.3g (B as a point: %.3g)\n", valid,
              checked, worst, worst_point);
  // The second-order expansion is well inside the estimate, and closer than B as a point.
  EXPECT_LT(worst, 0.1);
  EXPECT_LT(worst, 0.25 * worst_point);
  EXPECT_GT(valid, 200);
  EXPECT_GT(checked, 3000);
}

namespace {

// A room of 4 m × 3 m × 2.5 m, every side a grid of n × n quads, with a block above the floor and
// a floating cube (each side of those a grid too): enough faces for a tree of many levels.
pm::Scene meshed_room(int n, double rho, double emission) {
  pm::Scene s = builders::unit_cube(rho, emission);  // its material, without its faces
  s.vertices.clear();
  s.faces.clear();
  builders::add_meshed_box(s, pm::Vec3(0, 0, 0), pm::Vec3(4, 3, 2.5), n, true);
  builders::add_meshed_box(s, pm::Vec3(1.5, 1.0, 0.25), pm::Vec3(2.5, 2.0, 0.75), 2, false);
  builders::add_meshed_box(s, pm::Vec3(0.5, 2.0, 1.0), pm::Vec3(1.0, 2.5, 1.5), 2, false);
  return s;
}

pm::SolveResult solve(const pm::Scene& scene, double error, int cluster_above) {
  pm::SolveOptions opt;
  opt.method = pm::SolveMethod::Hierarchical;
  opt.hierarchical_error = error;
  opt.min_element_edge = 0.05;
  opt.cluster_above = cluster_above;
  opt.solver.tolerance = 1e-10;
  return pm::solve_scene(scene, opt);
}

}  // namespace

// The furnace (every face emits E = 1 and reflects ρ = 0.5, the room closed): B = 2 everywhere.
// Cluster links approximate their factors (clusters.h), so the error is what their estimate and
// refinement leave: below ε, or (where the smallest element already keeps the solve without
// clusters above ε) no worse than that solve by more than ε / 3.
TEST(HierarchicalClusters, FurnaceRoomIsWithinTheRequestedError) {
  const pm::Scene room = meshed_room(6, 0.5, 1.0);
  auto worst_of = [](const pm::SolveResult& r, double& mean) {
    double worst = 0.0;
    mean = 0.0;
    for (long o = 0; o < r.point_radiosity.rows(); ++o) {
      worst = std::max(worst, std::abs(r.point_radiosity(o, 0) - 2.0) / 2.0);
      mean += r.point_radiosity(o, 0) / double(r.point_radiosity.rows());
    }
    for (long i = 0; i < r.radiosity.rows(); ++i) worst = std::max(worst, std::abs(r.radiosity(i, 0) - 2.0) / 2.0);
    return worst;
  };
  for (double error : {1e-1, 5e-2}) {
    const pm::SolveResult r = solve(room, error, 0), plain = solve(room, error, -1);
    const pm::HierarchicalStats& h = r.summary.hierarchical;
    EXPECT_EQ(h.clusters, h.roots - 1);
    EXPECT_GT(h.cluster_links, 0);
    double mean = 0.0, plain_mean = 0.0;
    const double worst = worst_of(r, mean), plain_worst = worst_of(plain, plain_mean);
    std::printf(
        "furnace room, error %g: %d roots, %lld links (%lld with clusters), %d leaves: worst %.3g, mean %.6g; "
        "without clusters %lld links, worst %.3g\n",
        error, h.roots, h.links, h.cluster_links, h.leaves, worst, mean, plain.summary.hierarchical.links, plain_worst);
    EXPECT_LT(worst, std::max(error, plain_worst + error / 3)) << "error " << error;
    EXPECT_LT(std::abs(mean - 2.0) / 2.0, error / 3) << "error " << error;
  }
}

// Shadows: the same room lit by its floor (the block above it shadows the floor and the ceiling
// sees the block's top), solved with clusters and without, compared at the corners of the roots
// (output points both results have).
TEST(HierarchicalClusters, ShadowsAgreeWithTheSolveWithoutClusters) {
  pm::Scene room = meshed_room(6, 0.5, 0.0);
  pm::Material floor = room.materials[0];
  floor.name = "floor";
  floor.emission = pm::Rgb::Constant(1.0);
  room.materials.push_back(floor);
  for (int f = 0; f < 36; ++f) room.faces[size_t(f)].material = 1;  // the room's bottom side
  const double error = 0.05;
  const pm::SolveResult plain = solve(room, error, -1), clustered = solve(room, error, 0);
  ASSERT_EQ(plain.summary.hierarchical.clusters, 0);
  ASSERT_GT(clustered.summary.hierarchical.cluster_links, 0);
  std::map<std::array<long long, 6>, double> at;
  auto key = [](const pm::OutputPoint& p) {
    std::array<long long, 6> k;
    for (int i = 0; i < 3; ++i) {
      k[size_t(i)] = std::llround(p.position[i] * 1e6);
      k[size_t(i + 3)] = std::llround(p.normal[i] * 1e3);
    }
    return k;
  };
  for (size_t o = 0; o < plain.points.size(); ++o) at[key(plain.points[o])] = plain.point_radiosity(long(o), 0);
  double sum2 = 0.0, mean = 0.0, max = 0.0;
  int shared = 0;
  for (size_t o = 0; o < clustered.points.size(); ++o) {
    const auto it = at.find(key(clustered.points[o]));
    if (it == at.end()) continue;
    const double d = clustered.point_radiosity(long(o), 0) - it->second;
    sum2 += d * d;
    max = std::max(max, std::abs(d));
    mean += it->second;
    ++shared;
  }
  ASSERT_GT(shared, 200);
  mean /= shared;
  const double rms = std::sqrt(sum2 / shared) / mean;
  std::printf(
      "shadowed room, error %g: %d shared points, rms %.3g, max %.3g of the mean %.4g; links %lld against %lld\n",
      error, shared, rms, max / mean, mean, clustered.summary.hierarchical.links, plain.summary.hierarchical.links);
  EXPECT_LT(rms, error);
  EXPECT_LT(max / mean, 5 * error);
}

namespace {

// Appends a horizontal square of `size` centred over (0.5, 0.5) at height z, cut into n × n quads,
// each its own face, turned up or down; the scene's own materials and groups are kept.
void add_plate(pm::Scene& s, double z, double size, int n, bool up, int material) {
  const double shift = 0.5 - size / 2;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int v = int(s.vertices.size());
      const double x0 = shift + size * i / n, x1 = shift + size * (i + 1) / n, y0 = shift + size * j / n,
                   y1 = shift + size * (j + 1) / n;
      for (const pm::Vec3& p : {pm::Vec3(x0, y0, z), pm::Vec3(x1, y0, z), pm::Vec3(x1, y1, z), pm::Vec3(x0, y1, z)})
        s.vertices.push_back(p);
      s.faces.push_back(up ? pm::Face{{v, v + 1, v + 2, v + 3}, material, 0, int(s.faces.size())}
                           : pm::Face{{v, v + 3, v + 2, v + 1}, material, 0, int(s.faces.size())});
    }
}

// A scene without faces, its materials grey (0: reflects 0.5) and lamp (1: emits 1).
pm::Scene grey_and_lamp() {
  pm::Scene s = builders::unit_cube(0.5, 0.0);
  s.vertices.clear();
  s.faces.clear();
  pm::Material lamp;
  lamp.name = "lamp";
  lamp.emission = pm::Rgb::Constant(1.0);
  s.materials.push_back(lamp);
  return s;
}

// The hierarchy with clusters from two faces on, and a large ε (0.3): clusters of a few faces
// pass the error test.
pm::SolveResult solve_clustered(const pm::Scene& s, double min_element) {
  pm::SolveOptions opt;
  opt.method = pm::SolveMethod::Hierarchical;
  opt.hierarchical_error = 0.3;
  opt.min_element_edge = min_element;
  opt.cluster_above = 0;
  return pm::solve_scene(s, opt);
}

}  // namespace

// A shelf under a small lamp 5 m above: two plates, the lower one (3 × 3 faces) wholly in the
// upper one's shadow. Their faces all turn toward the lamp, and nothing else lies between, so
// only a shelf cluster's convexity (it is not: the upper plate lies in front of the lower one's
// plane) keeps the lamp from being linked to it as if nothing of it shaded the rest (the large ε
// of solve_clustered lets clusters of the upper plate and parts of the lower one pass the error
// test).
TEST(HierarchicalClusters, AShadowInsideAClusterIsKept) {
  pm::Scene s = grey_and_lamp();
  add_plate(s, 0.9, 1.0, 3, true, 0);   // faces 0..8: the lower plate, in the upper one's shadow
  add_plate(s, 1.0, 1.0, 1, true, 0);   // face 9: the upper plate, one face (an occluder of its own)
  add_plate(s, 6.0, 0.5, 1, false, 1);  // face 10: the lamp, turned down
  const pm::SolveResult r = solve_clustered(s, 0.05);
  EXPECT_EQ(r.summary.hierarchical.clusters, 10);
  double upper = 0.0, lower = 0.0;
  for (long i = 0; i < r.radiosity.rows(); ++i) {
    const int face = r.mesh.patches[size_t(i)].face;
    if (face < 9) lower = std::max(lower, r.radiosity(i, 0));
    else if (face == 9) upper = std::max(upper, r.radiosity(i, 0));
  }
  std::printf("shelf: upper plate up to %.4g, lower plate up to %.4g, %lld cluster links\n", upper, lower,
              r.summary.hierarchical.cluster_links);
  EXPECT_GT(upper, 1e-3);
  EXPECT_LT(lower, 1e-12);
}

// A plate of 3 × 3 faces under a small lamp 5 m above, and between them a panel that only
// obstructs (a View3D `O` surface: no patches, no roots): the plate's cluster and the lamp may
// not be linked through the panel, which is no face of either.
TEST(HierarchicalClusters, AnObstructionBetweenClustersBlocksTheirLink) {
  for (const bool obstructed : {false, true}) {
    pm::Scene s = grey_and_lamp();
    add_plate(s, 0.0, 1.0, 3, true, 0);   // faces 0..8: the plate, turned up
    add_plate(s, 5.0, 0.5, 1, false, 1);  // face 9: the lamp, turned down
    if (obstructed) {
      add_plate(s, 2.5, 3.0, 1, true, 0);  // face 10: the panel, wider than the plate
      s.faces.back().obstruction_only = true;
    }
    const pm::SolveResult r = solve_clustered(s, 0.2);
    double plate = 0.0;
    for (long i = 0; i < r.radiosity.rows(); ++i)
      if (r.mesh.patches[size_t(i)].face < 9) plate = std::max(plate, r.radiosity(i, 0));
    std::printf("plate under a lamp%s: up to %.4g, %lld cluster links\n", obstructed ? ", obstructed" : "", plate,
                r.summary.hierarchical.cluster_links);
    if (obstructed) {
      EXPECT_EQ(plate, 0.0);
    } else {
      EXPECT_GT(plate, 1e-3);
      EXPECT_GT(r.summary.hierarchical.cluster_links, 0);  // the plate's cluster and the lamp, linked
    }
  }
}
