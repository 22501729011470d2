// Occluders from surfaces, not faces (visibility.h, ShaftCuller): coplanar, edge-connected faces
// merged into convex polygons that cover exactly what the faces cover, and exact visibility
// through them equal to exact visibility through the faces.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <tuple>

#include "kernels/lambert.h"
#include "scene_builders.h"
#include "validation/bench.h"
#include "visibility/visibility.h"

using namespace photometria;

namespace {

// Appends a grid of n × m quads in the plane z = h (corner (x0, y0), cell size dx × dy), facing
// +z (or −z with `down`), sharing their vertices; cells where skip(i, j) are left out.
template <class Skip>
void add_grid(Scene& s, double x0, double y0, double dx, double dy, int n, int m, double h, bool down, Skip skip) {
  std::map<std::pair<int, int>, int> id;
  auto vertex = [&](int i, int j) {
    const auto [it, fresh] = id.emplace(std::make_pair(i, j), static_cast<int>(s.vertices.size()));
    if (fresh) s.vertices.emplace_back(x0 + i * dx, y0 + j * dy, h);
    return it->second;
  };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      if (skip(i, j)) continue;
      std::vector<int> v = {vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)};
      if (down) std::reverse(v.begin(), v.end());
      s.faces.push_back({v, 0, 0, static_cast<int>(s.faces.size())});
    }
}

// Appends the box [lo, hi] with outward faces, each side meshed into m × m quads sharing vertices.
void add_meshed_box(Scene& s, const Vec3& lo, const Vec3& hi, int m) {
  std::map<std::tuple<int, int, int>, int> id;
  auto vertex = [&](int i, int j, int k) {
    const auto [it, fresh] = id.emplace(std::make_tuple(i, j, k), static_cast<int>(s.vertices.size()));
    if (fresh) {
      const Vec3 t(i, j, k);
      s.vertices.push_back(lo + (hi - lo).cwiseProduct(t / m));
    }
    return it->second;
  };
  for (int a = 0; a < 3; ++a)
    for (int side = 0; side < 2; ++side) {
      const int u = (a + 1) % 3, v = (a + 2) % 3;  // u × v = a
      for (int p = 0; p < m; ++p)
        for (int q = 0; q < m; ++q) {
          std::vector<int> c;
          for (const auto& [du, dv] : {std::pair{0, 0}, {1, 0}, {1, 1}, {0, 1}}) {
            int l[3];
            l[a] = side * m;
            l[u] = p + du;
            l[v] = q + dv;
            c.push_back(vertex(l[0], l[1], l[2]));
          }
          if (side == 0) std::reverse(c.begin(), c.end());  // facing −a
          s.faces.push_back({c, 0, 0, static_cast<int>(s.faces.size())});
        }
    }
}

Scene empty_scene() {
  Scene s;
  s.source = "test";
  s.materials = {Material{}};
  s.groups = {"test"};
  return s;
}

// True when y lies strictly inside convex polygon p (counter-clockwise around its normal n).
bool inside(const Polygon& p, const Vec3& n, const Vec3& y) {
  for (size_t k = 0; k < p.size(); ++k)
    if (!(n.dot((p[(k + 1) % p.size()] - p[k]).cross(y - p[k])) > 1e-12)) return false;
  return true;
}

std::vector<int> all(int n) {
  std::vector<int> w(static_cast<size_t>(n));
  std::iota(w.begin(), w.end(), 0);
  return w;
}

}  // namespace

TEST(VisibilityOccluders, AWallOfQuadsIsOneOccluder) {
  for (bool down : {false, true}) {
    Scene s = empty_scene();
    add_grid(s, 0.0, 0.0, 0.1, 0.2, 12, 7, 1.0, down, [](int, int) { return false; });
    const ShaftCuller culler(s);
    ASSERT_EQ(culler.scene_face_count(), 84);
    ASSERT_EQ(culler.occluder_count(), 1);
    const Polygon& w = culler.occluder_polygons()[0];
    EXPECT_EQ(w.size(), 4u);  // the straight corners along its edges removed
    EXPECT_NEAR(polygon_area(w), 1.2 * 1.4, 1e-12);
    EXPECT_NEAR(culler.occluder_normals()[0].z(), down ? -1.0 : 1.0, 1e-15);
    EXPECT_EQ(culler.occluder_faces(0), all(84));
    for (int f = 0; f < 84; ++f) EXPECT_EQ(culler.occluder_of_face(f), 0);
    EXPECT_EQ(culler.scene_faces()[5], s.face_polygon(5));
  }
  // The same quads with a vertex each of their own (a scene not welded, as load_scene would):
  // no edge is shared, nothing is merged.
  Scene s = empty_scene();
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 5; ++i) {
      const int b = static_cast<int>(s.vertices.size());
      s.vertices.push_back(Vec3(i, j, 0.0) * 0.2);
      s.vertices.push_back(Vec3(i + 1, j, 0.0) * 0.2);
      s.vertices.push_back(Vec3(i + 1, j + 1, 0.0) * 0.2);
      s.vertices.push_back(Vec3(i, j + 1, 0.0) * 0.2);
      s.faces.push_back({{b, b + 1, b + 2, b + 3}, 0, 0, static_cast<int>(s.faces.size())});
    }
  EXPECT_EQ(ShaftCuller(s).occluder_count(), 25);
}

TEST(VisibilityOccluders, FacesOfAnotherPlaneOrOrientationStayApart) {
  Scene s = empty_scene();
  add_grid(s, 0.0, 0.0, 0.5, 0.5, 2, 1, 0.0, false, [](int, int) { return false; });
  add_grid(s, 1.0, 0.0, 0.5, 0.5, 1, 1, 0.0, true, [](int, int) { return false; });    // facing down
  add_grid(s, 0.0, 0.5, 0.5, 0.5, 1, 1, 1e-3, false, [](int, int) { return false; });  // 1 mm above
  const ShaftCuller culler(s);
  EXPECT_EQ(culler.occluder_count(), 3);
  EXPECT_EQ(culler.occluder_faces(0), (std::vector<int>{0, 1}));
  EXPECT_EQ(culler.occluder_polygons()[1], s.face_polygon(2));  // alone: the face itself
}

TEST(VisibilityOccluders, AMeshedBoxIsSixOccludersAndOneConvexSolid) {
  Scene s = empty_scene();
  add_meshed_box(s, Vec3(0.2, 0.3, 0.0), Vec3(0.5, 0.4, 0.7), 4);
  const ShaftCuller culler(s);
  ASSERT_EQ(culler.scene_face_count(), 96);
  ASSERT_EQ(culler.occluder_count(), 6);
  for (const Polygon& w : culler.occluder_polygons()) EXPECT_EQ(w.size(), 4u);
  EXPECT_EQ(culler.convex_solid_count(), 1);
  EXPECT_EQ(culler.solid_occluders(0), all(6));
  for (int o = 0; o < 6; ++o)
    for (int k = 0; k < 4; ++k) EXPECT_GE(culler.neighbour(o, k), 0);
  // The same box of 6 faces is the same solid.
  Scene plain = empty_scene();
  builders::add_box(plain, Vec3(0.2, 0.3, 0.0), Vec3(0.5, 0.4, 0.7));
  EXPECT_EQ(ShaftCuller(plain).convex_solid_count(), 1);
}

TEST(VisibilityOccluders, AnLShapedGroupIsSplitIntoConvexPiecesCoveringTheSameArea) {
  Scene s = empty_scene();
  // 4 × 4 quads of 0.25 m without the 2 × 2 in the corner (x, y > 0.5): an L of 12 quads.
  auto notch = [](int i, int j) { return i >= 2 && j >= 2; };
  add_grid(s, 0.0, 0.0, 0.25, 0.25, 4, 4, 0.5, false, notch);
  const ShaftCuller culler(s);
  ASSERT_EQ(culler.scene_face_count(), 12);
  EXPECT_GE(culler.occluder_count(), 2);
  EXPECT_LE(culler.occluder_count(), 3);
  double area = 0.0;
  for (int o = 0; o < culler.occluder_count(); ++o) {
    const Polygon& w = culler.occluder_polygons()[size_t(o)];
    EXPECT_TRUE(is_convex(w)) << o;
    area += polygon_area(w);
    for (int f : culler.occluder_faces(o)) EXPECT_EQ(culler.occluder_of_face(f), o);
  }
  EXPECT_NEAR(area, 12 * 0.0625, 1e-14);
  // Points off the quads' edges: inside exactly one occluder when in the L, else in none.
  for (int j = 0; j < 40; ++j)
    for (int i = 0; i < 40; ++i) {
      const Vec3 y((i + 0.5) / 40.0 * 1.1 - 0.05, (j + 0.5) / 40.0 * 1.1 - 0.05, 0.5);
      const bool in_l = y.x() > 0 && y.x() < 1 && y.y() > 0 && y.y() < 1 && !(y.x() > 0.5 && y.y() > 0.5);
      int count = 0;
      for (const Polygon& w : culler.occluder_polygons()) count += inside(w, Vec3::UnitZ(), y);
      EXPECT_EQ(count, in_l ? 1 : 0) << y.transpose();
    }
  // A ring (a plate with a hole) is split too, and keeps its hole.
  Scene ring = empty_scene();
  add_grid(ring, 0.0, 0.0, 0.25, 0.25, 4, 4, 0.5, false, [](int i, int j) { return i == 1 && j == 2; });
  const ShaftCuller rc(ring);
  EXPECT_GE(rc.occluder_count(), 2);
  double ring_area = 0.0;
  for (const Polygon& w : rc.occluder_polygons()) {
    EXPECT_TRUE(is_convex(w));
    ring_area += polygon_area(w);
    EXPECT_FALSE(inside(w, Vec3::UnitZ(), Vec3(0.375, 0.625, 0.5)));  // the hole's centre
  }
  EXPECT_NEAR(ring_area, 15 * 0.0625, 1e-14);
}

TEST(VisibilityOccluders, GroundAroundCityBlocksIsAFewConvexPiecesCoveringIt) {
  // 3 × 3 buildings' footprints (8 × 8 cells) cut out of a 40 × 40 ground, streets 4 cells
  // wide: 1,024 quads in one plane with nine holes. The pieces grow quad by quad, so this also
  // takes the merging's every path (strips, strips into rectangles, refusals at the holes).
  Scene s = empty_scene();
  auto building = [](int i) { return i % 12 >= 4 && i < 36; };
  add_grid(s, 0.0, 0.0, 0.5, 0.5, 40, 40, 0.0, false, [&](int i, int j) { return building(i) && building(j); });
  const ShaftCuller culler(s);
  ASSERT_EQ(culler.scene_face_count(), 1024);
  EXPECT_LE(culler.occluder_count(), 24);  // 14 as grown now; a strip per row of cells would be 16 + 36
  double area = 0.0;
  std::vector<int> covered(1024, 0);
  for (int o = 0; o < culler.occluder_count(); ++o) {
    const Polygon& w = culler.occluder_polygons()[size_t(o)];
    EXPECT_TRUE(is_convex(w)) << o;
    area += polygon_area(w);
    for (int f : culler.occluder_faces(o)) {
      EXPECT_EQ(culler.occluder_of_face(f), o);
      ++covered[size_t(f)];
    }
  }
  EXPECT_NEAR(area, 1024 * 0.25, 1e-9);
  EXPECT_EQ(std::count(covered.begin(), covered.end(), 1), 1024);
  for (int j = 0; j < 80; ++j)  // quarter-cell points: inside one occluder on the ground, none in a hole
    for (int i = 0; i < 80; ++i) {
      const Vec3 y((i + 0.5) * 0.25, (j + 0.5) * 0.25, 0.0);
      const bool hole = building(i / 2) && building(j / 2);
      int count = 0;
      for (const Polygon& w : culler.occluder_polygons()) count += inside(w, Vec3::UnitZ(), y);
      ASSERT_EQ(count, hole ? 0 : 1) << y.transpose();
    }
}

TEST(VisibilityOccluders, AFaceThatIsNotConvexStaysAnOccluderOfItsOwn) {
  // An L-shaped hexagon beside two quads of the same plane: the quads merge, the L stays alone
  // (pieces grow only from convex faces, so that a union is convex when its two seams are).
  Scene s = empty_scene();
  s.vertices = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0},  // the L
                {3, 0, 0}, {3, 1, 0}, {4, 0, 0}, {4, 1, 0}};
  s.faces.push_back({{0, 1, 2, 3, 4, 5}, 0, 0, 0});
  s.faces.push_back({{1, 6, 7, 2}, 0, 0, 1});
  s.faces.push_back({{6, 8, 9, 7}, 0, 0, 2});
  const ShaftCuller culler(s);
  ASSERT_EQ(culler.occluder_count(), 2);
  EXPECT_EQ(culler.occluder_faces(0), std::vector<int>{0});
  EXPECT_EQ(culler.occluder_faces(1), (std::vector<int>{1, 2}));
  EXPECT_NEAR(polygon_area(culler.occluder_polygons()[1]), 2.0, 1e-14);
}

TEST(VisibilityOccluders, ExactFactorsThroughMergedOccludersEqualThoseThroughTheFaces) {
  Scene s = empty_scene();
  // A plate of 6 × 5 quads, an L of quads and a meshed box between a floor receiver and a source above.
  add_grid(s, -0.6, -0.4, 0.1, 0.1, 6, 5, 0.8, false, [](int, int) { return false; });
  add_grid(s, 0.1, -0.5, 0.15, 0.15, 4, 4, 1.1, true, [](int i, int j) { return i < 2 && j >= 2; });
  add_meshed_box(s, Vec3(-0.3, 0.3, 0.3), Vec3(0.0, 0.6, 0.6), 3);
  const ShaftCuller culler(s);
  EXPECT_LT(culler.occluder_count(), 12);
  EXPECT_EQ(culler.convex_solid_count(), 1);
  const std::vector<int> occluders = all(culler.occluder_count()), faces = all(culler.scene_face_count());
  const Polygon source = {{-1.0, -1.0, 1.6}, {-1.0, 1.0, 1.6}, {1.0, 1.0, 1.6}, {1.0, -1.0, 1.6}};  // facing down
  int shadowed = 0;
  for (int j = 0; j < 9; ++j)
    for (int i = 0; i < 9; ++i) {
      const Receiver x{Vec3(-1.0 + i * 0.25, -1.0 + j * 0.25, 0.0), Vec3::UnitZ()};
      const double by_faces = exact_visible_form_factor(x, source.data(), 4, culler.scene_faces(), faces);
      const double merged = exact_visible_form_factor(x, source.data(), 4, culler.occluder_polygons(), occluders);
      const double with_solids = exact_visible_form_factor(x, source.data(), 4, culler.occluder_polygons(), occluders,
                                                           &culler.occluder_normals(), &culler);
      EXPECT_NEAR(merged, by_faces, 1e-12 * lambert_form_factor(x, source.data(), 4)) << i << " " << j;
      EXPECT_NEAR(with_solids, by_faces, 1e-12 * lambert_form_factor(x, source.data(), 4)) << i << " " << j;
      shadowed += by_faces < lambert_form_factor(x, source.data(), 4) - 1e-9;
    }
  EXPECT_GT(shadowed, 40);
}

TEST(VisibilityOccluders, ScenesOfBigFacesKeepOneOccluderPerFace) {
  const Scene room = validation::bench_room_scene();
  const ShaftCuller culler(room);
  ASSERT_EQ(culler.occluder_count(), culler.scene_face_count());
  for (int f = 0; f < culler.scene_face_count(); ++f) {
    EXPECT_EQ(culler.occluder_of_face(f), f);
    EXPECT_EQ(culler.occluder_polygons()[size_t(f)], room.face_polygon(f));
  }
}

// A scanned object: a closed solid that is not convex. Its back occluders go for points outside
// it, and exact factors through what is left equal those through every occluder.
TEST(VisibilityOccluders, AClosedNonConvexSolidCastsItsShadowThroughItsFrontOccluders) {
  Scene s = empty_scene();
  const Vec3 centre(0.1, -0.05, 0.5);
  builders::add_bumpy_sphere(s, centre, 0.3, 9, 12, 0.25);
  const int solid_faces = static_cast<int>(s.faces.size());
  // A floor quad just below it (its lowest corners at z = 0.5 − 0.3 · 1.25 cos 20° > 0.14).
  add_grid(s, -1.0, -1.0, 2.0, 2.0, 1, 1, 0.14, false, [](int, int) { return false; });
  const ShaftCuller culler(s);
  EXPECT_EQ(culler.convex_solid_count(), 0);
  ASSERT_EQ(culler.closed_solid_count(), 1);
  for (int f = 0; f < solid_faces; ++f) EXPECT_EQ(culler.closed_solid_of(culler.occluder_of_face(f)), 0);
  EXPECT_EQ(culler.closed_solid_of(culler.occluder_of_face(solid_faces)), -1);  // the floor

  const std::vector<int> everything = all(culler.occluder_count());
  const Polygon source = {{-1.5, -1.5, 1.4}, {-1.5, 1.5, 1.4}, {1.5, 1.5, 1.4}, {1.5, -1.5, 1.4}};  // facing down
  // Checks x (on_face, normal as drop_hidden_occluders takes them): the factor through the kept
  // occluders equals the one through all; returns how many were dropped.
  auto check = [&](const Receiver& x, int on_face, const Polygon& src) {
    std::vector<int> kept = everything;
    culler.drop_hidden_occluders(x.point, kept, on_face, &x.normal);
    const double f0 = lambert_form_factor(x, src.data(), int(src.size()));
    const double want =
        exact_visible_form_factor(x, src.data(), int(src.size()), culler.occluder_polygons(), everything);
    const double got = exact_visible_form_factor(x, src.data(), int(src.size()), culler.occluder_polygons(), kept);
    EXPECT_NEAR(got, want, 1e-13 + 1e-12 * f0) << x.point.transpose() << " on face " << on_face;
    return static_cast<int>(everything.size() - kept.size());
  };
  // Floor points under the solid (inside its bounding box, outside by the crossings' parity) and
  // beside it: the solid's upper occluders, which they lie behind, are dropped.
  int dropped_on_floor = 0, floor_points = 0;
  for (int j = 0; j < 9; ++j)
    for (int i = 0; i < 9; ++i) {
      const Receiver x{Vec3(-0.4 + i * 0.1 + 0.013, -0.55 + j * 0.1 + 0.007, 0.14), Vec3::UnitZ()};
      dropped_on_floor += check(x, solid_faces, source) > 0;
      ++floor_points;
    }
  EXPECT_EQ(dropped_on_floor, floor_points);
  // Beside it, inside its bounding box (at 0.39 m from the centre, diagonally; the solid reaches
  // 0.375 m at most): outside by the parity of the crossings.
  int dropped_beside = 0;
  for (int k = 0; k < 4; ++k) {
    const double a = 0.785398 + k * 1.570796;
    const Vec3 out(std::cos(a), std::sin(a), 0.0);
    const Receiver x{centre + 0.39 * out, out};
    const Vec3 u = Vec3::UnitZ(), v = out.cross(u);
    Polygon in_front;
    for (const auto& [p, q] : {std::pair{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}})
      in_front.push_back(x.point + 0.6 * out + 0.4 * (p * u + q * v));
    std::reverse(in_front.begin(), in_front.end());
    dropped_beside += check(x, -1, in_front) > 0;
  }
  EXPECT_EQ(dropped_beside, 4);
  // A vertex of the solid without a normal: a segment may start into the solid there.
  std::vector<int> kept = everything;
  culler.drop_hidden_occluders(s.vertices[0], kept);
  EXPECT_EQ(kept.size(), everything.size());
  // Inside the solid: a segment may leave it through any occluder, so every one is kept.
  kept = everything;
  culler.drop_hidden_occluders(centre, kept);
  EXPECT_EQ(kept.size(), everything.size());
  // On its own faces (a patch's quadrature point inside a face), toward a source in front of
  // each face: the back occluders go, the factor stays.
  int dropped_on_faces = 0;
  for (int f = 0; f < solid_faces; f += 5) {
    const Polygon w = s.face_polygon(f);
    const Vec3 n = polygon_normal(w), c = polygon_centroid(w);
    const Vec3 u = (w[1] - w[0]).normalized(), v = n.cross(u);
    Polygon in_front;
    for (const auto& [a, b] : {std::pair{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}})
      in_front.push_back(c + 0.8 * n + 0.3 * (a * u + b * v));
    std::reverse(in_front.begin(), in_front.end());  // facing back toward the face
    dropped_on_faces += check(Receiver{c, n}, f, in_front) > 0;
  }
  EXPECT_GT(dropped_on_faces, 0);
  // At its vertices, with the normal of a face there (a gather point): dropped only where that
  // is exact (convex vertices); the factor stays everywhere, saddles included.
  int dropped_at_vertices = 0;
  for (int f = 0; f < solid_faces; f += 3) {
    const Polygon w = s.face_polygon(f);
    const Vec3 n = polygon_normal(w);
    Polygon in_front;
    for (const auto& [a, b] : {std::pair{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}}) {
      const Vec3 u = (w[1] - w[0]).normalized(), v = n.cross(u);
      in_front.push_back(w[0] + 0.8 * n + 0.3 * (a * u + b * v));
    }
    std::reverse(in_front.begin(), in_front.end());
    dropped_at_vertices += check(Receiver{w[0], n}, -1, in_front) > 0;
  }
  EXPECT_GT(dropped_at_vertices, 0);
}

TEST(VisibilityOccluders, AClosedRoomIsNoSolid) {
  // Its normals point inward: the room is the outside of what its faces bound.
  const Scene room = builders::unit_cube();
  const ShaftCuller culler(room);
  EXPECT_EQ(culler.convex_solid_count(), 0);
  EXPECT_EQ(culler.closed_solid_count(), 0);
}

// The tree search prunes whole subtrees by a shaft's planes; what it finds is what testing every
// occluder finds (occluders_among over all of them, no tree), for point shafts and face shafts.
TEST(VisibilityOccluders, TheTreeFindsWhatTestingEveryOccluderFinds) {
  Scene s = builders::unit_cube();
  builders::add_bumpy_sphere(s, {0.5, 0.45, 0.4}, 0.25, 14, 18, 0.15);
  builders::add_box(s, {0.1, 0.1, 0.0}, {0.25, 0.2, 0.6});
  const ShaftCuller culler(s);
  const std::vector<int> everything = all(culler.occluder_count());
  std::vector<int> by_tree, by_list;
  int found = 0;
  for (int i = 0; i < 300; ++i) {
    // Points on the room's faces and on the object, shafts to every 7th face.
    const Polygon w = s.face_polygon(i % culler.scene_face_count());
    const Vec3 x = polygon_centroid(w);
    for (int f = (i * 13) % 7; f < culler.scene_face_count(); f += 7) {
      const Polygon& b = culler.scene_faces()[size_t(f)];
      culler.occluders(&x, 1, b.data(), int(b.size()), by_tree);
      culler.occluders_among(&x, 1, b.data(), int(b.size()), everything, by_list);
      ASSERT_EQ(by_tree, by_list) << "point " << i << " face " << f;
      found += !by_tree.empty();
      // And the shaft of the two faces (pruned by its planes once a candidate has built them).
      culler.occluders(w.data(), int(w.size()), b.data(), int(b.size()), by_tree);
      culler.occluders_among(w.data(), int(w.size()), b.data(), int(b.size()), everything, by_list);
      ASSERT_EQ(by_tree, by_list) << "face " << i << " face " << f;
    }
  }
  EXPECT_GT(found, 1000);
}

// Two axis-aligned boxes given in box_corners' order take Haines & Wallace's box-to-box planes
// (shaft_culler.cpp). Still conservative: every occluder that some segment between the boxes
// crosses (4,000 random segments a pair) is found, and no more are found than with the same
// corners in another order (the general hull's candidates).
TEST(VisibilityOccluders, BoxToBoxShaftsKeepEveryOccluderASegmentCrosses) {
  Scene s = builders::unit_cube();
  builders::add_bumpy_sphere(s, {0.5, 0.45, 0.4}, 0.25, 14, 18, 0.15);
  builders::add_box(s, {0.1, 0.1, 0.0}, {0.25, 0.2, 0.6});
  const ShaftCuller culler(s);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto random_box = [&] {
    const Vec3 lo(u(rng) * 0.8, u(rng) * 0.8, u(rng) * 0.8);
    Vec3 size(u(rng) * 0.2, u(rng) * 0.2, u(rng) * 0.2);
    size[int(u(rng) * 3) % 3] *= u(rng) < 0.3 ? 0.0 : 1.0;  // some flat, as a wall's cluster
    return Eigen::AlignedBox3d(lo, lo + size);
  };
  // Whether segment p–q crosses occluder o's open polygon.
  auto crosses = [&](const Vec3& p, const Vec3& q, int o) {
    const Polygon& w = culler.occluder_polygons()[size_t(o)];
    const Vec3& n = culler.occluder_normals()[size_t(o)];
    const double sp = n.dot(p - w[0]), sq = n.dot(q - w[0]);
    if (!(sp * sq < 0.0)) return false;
    const Vec3 x = p + (sp / (sp - sq)) * (q - p);
    for (size_t k = 0; k < w.size(); ++k)
      if (n.dot((w[(k + 1) % w.size()] - w[k]).cross(x - w[k])) <= 0.0) return false;
    return true;
  };
  long long by_box_planes = 0, by_general_hull = 0, crossed = 0;
  std::vector<int> box_path, general_path;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::AlignedBox3d a = random_box(), b = random_box();
    Vec3 ca[8], cb[8];
    box_corners(a, ca);
    box_corners(b, cb);
    culler.occluders(ca, 8, cb, 8, box_path);
    std::reverse(ca, ca + 8);  // the same corners, not in box_corners' order: the general hull
    std::reverse(cb, cb + 8);
    culler.occluders(ca, 8, cb, 8, general_path);
    by_box_planes += long(box_path.size());
    by_general_hull += long(general_path.size());
    for (int k = 0; k < 4000; ++k) {
      const Vec3 p = a.min() + (a.max() - a.min()).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
      const Vec3 q = b.min() + (b.max() - b.min()).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
      for (const int o : general_path)
        if (crosses(p, q, o)) {
          ++crossed;
          ASSERT_TRUE(std::binary_search(box_path.begin(), box_path.end(), o))
              << "trial " << trial << ": occluder " << o << " crossed but not kept";
        }
    }
  }
  std::printf("occluders kept: %lld by box-to-box planes, %lld by the general hull; %lld crossings checked\n",
              by_box_planes, by_general_hull, crossed);
  EXPECT_GT(crossed, 10000);
  EXPECT_LE(by_box_planes, by_general_hull);
}
