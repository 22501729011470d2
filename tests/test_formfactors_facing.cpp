// FacingGroups (formfactors/facing.h): every decided pair agrees with facing_away, and the runs
// groups decide almost all pairs of a room.
#include <gtest/gtest.h>

#include <string>

#include "formfactors/facing.h"
#include "formfactors/formfactors.h"
#include "scene/scene.h"
#include "scene_builders.h"
#include "validation/bench.h"

using namespace photometria;
using builders::add_box;
using builders::unit_cube;
using validation::bench_room_patching;
using validation::bench_room_scene;

namespace {

struct Tally {
  long long away = 0, toward = 0, test = 0, wrong = 0;
  // One pair: the group's answer and the pair test's (`away`).
  void add(Facing f, bool pair_away) {
    if (f == Facing::Away) ++away, wrong += !pair_away;
    if (f == Facing::Toward) ++toward, wrong += pair_away;
    if (f == Facing::Test) ++test;
  }
};

Tally check_all_pairs(const PatchMesh& mesh) {
  const double tol = plane_tolerance(mesh);
  const FacingGroups runs(mesh, tol);
  std::vector<Facing> state(static_cast<size_t>(mesh.size()));
  Tally t;
  for (int i = 0; i < mesh.size(); ++i) {
    runs.classify(i, state.data());
    for (int j = 0; j < mesh.size(); ++j) {
      if (j == i) continue;
      const bool away = facing_away(mesh, i, j, tol);
      t.add(state[size_t(j)], away);
    }
  }
  return t;
}

// classify_point against point_facing_away, from every corner of every patch (the vertex
// gather's output points) with that patch's normal.
Tally check_all_points(const PatchMesh& mesh) {
  const double tol = plane_tolerance(mesh);
  const FacingGroups runs(mesh, tol);
  std::vector<Facing> state(static_cast<size_t>(mesh.size()));
  Tally t;
  for (int i = 0; i < mesh.size(); ++i) {
    const Patch& p = mesh.patches[size_t(i)];
    for (int c = 0; c < p.corner_count; ++c) {
      const Vec3& x = mesh.points[size_t(p.corners[size_t(c)])];
      runs.classify_point(x, p.normal, state.data());
      for (int j = 0; j < mesh.size(); ++j) {
        const bool away = point_facing_away(mesh, x, p.normal, j, tol);
        t.add(state[size_t(j)], away);
      }
    }
  }
  return t;
}

}  // namespace

TEST(FacingGroups, PointsAgreeWithTheGathersTest) {
  for (const PatchMesh& mesh : {subdivide(bench_room_scene(), bench_room_patching(0.24)),
                                subdivide(load_scene(std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj"),
                                          PatchingOptions{0.25, 0.0})}) {
    const Tally t = check_all_points(mesh);
    EXPECT_EQ(t.wrong, 0);
    EXPECT_GT(t.away, 0);
    EXPECT_GT(t.toward, 0);
    EXPECT_GT(t.away + t.toward, 10 * t.test) << t.away << " " << t.toward << " " << t.test;
  }
}

TEST(FacingGroups, AgreesWithThePairTestInTheBenchRoom) {
  const PatchMesh mesh = subdivide(bench_room_scene(), bench_room_patching(0.24));
  const Tally t = check_all_pairs(mesh);
  EXPECT_EQ(t.wrong, 0);
  EXPECT_GT(t.away, 0);
  EXPECT_GT(t.toward, 0);
  // Left to the pair test: only groups a receiver's plane passes through.
  const double pairs = double(mesh.size()) * (mesh.size() - 1);
  EXPECT_LT(double(t.test), 0.05 * pairs) << t.away << " " << t.toward << " " << t.test;
}

TEST(FacingGroups, AgreesWithThePairTestInTheCornellBox) {
  const Scene box = load_scene(std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj");
  const PatchMesh mesh = subdivide(box, PatchingOptions{0.1, 0.0});
  const Tally t = check_all_pairs(mesh);
  EXPECT_EQ(t.wrong, 0);
  EXPECT_GT(t.away + t.toward, 20 * t.test) << t.away << " " << t.toward << " " << t.test;
}

// Patches with a normal of their own form groups of one; boxes
// touching the receiver's plane (adjacent walls, the floor under a box) are decided right.
TEST(FacingGroups, AgreesForSinglePatchRunsAndTouchingBoxes) {
  Scene s = unit_cube();
  add_box(s, Vec3(0.2, 0.2, 0.0), Vec3(0.5, 0.6, 0.3));
  add_box(s, Vec3(0.6, 0.1, 0.0), Vec3(0.9, 0.4, 0.7));
  const PatchMesh mesh = subdivide(s, PatchingOptions{0.1, 0.0});
  const Tally t = check_all_pairs(mesh);
  EXPECT_EQ(t.wrong, 0);
  EXPECT_GT(t.away, 0);
  EXPECT_GT(t.toward, 0);

  // Every patch a run of its own: tilt each patch's normal by a different amount.
  PatchMesh tilted = mesh;
  for (int j = 0; j < tilted.size(); ++j) {
    Patch& p = tilted.patches[size_t(j)];
    p.normal = (p.normal + Vec3(1.0, 1.0, 1.0) * (1e-9 * (j % 7))).normalized();
  }
  EXPECT_EQ(FacingGroups(tilted, plane_tolerance(tilted)).group_count(), tilted.size());
  EXPECT_EQ(check_all_pairs(tilted).wrong, 0);
}

// The kernel restricted to facing sources: every source not classified Away gets the full
// kernel's value bit for bit; a run of at least 8 Away sources is skipped (0), a shorter one is
// evaluated with its neighbours.
TEST(FacingGroups, KernelForFacingSourcesEqualsTheFullKernel) {
  const PatchMesh mesh = subdivide(bench_room_scene(), bench_room_patching(0.24));
  const FacingGroups groups(mesh, plane_tolerance(mesh));
  const PolygonBatch sources = patch_batch(mesh);
  const int n = mesh.size();
  std::vector<Facing> facing(static_cast<size_t>(n));
  std::vector<double> full(static_cast<size_t>(n)), restricted(static_cast<size_t>(n));
  long long away = 0;
  for (int i = 0; i < n; i += 7) {
    const Patch& p = mesh.patches[size_t(i)];
    groups.classify_point(p.centroid, p.normal, facing.data());
    const Receiver at{p.centroid, p.normal};
    lambert_form_factors(at, sources, full.data());
    std::fill(restricted.begin(), restricted.end(), -1.0);
    lambert_form_factors_facing(at, sources, facing.data(), restricted.data());
    for (int j = 0; j < n; ++j) {
      ASSERT_GE(restricted[size_t(j)], 0.0) << i << " " << j;  // every entry written
      if (facing[size_t(j)] == Facing::Away) ++away;
      else ASSERT_EQ(restricted[size_t(j)], full[size_t(j)]) << i << " " << j;  // bit for bit
    }
  }
  EXPECT_GT(away, 0);
  // Runs forced on sources the point sees: 10 Away in a row are skipped, 3 are not.
  const Patch& floor_patch = mesh.patches[0];
  const Receiver up{floor_patch.centroid + 0.5 * floor_patch.normal, floor_patch.normal};
  lambert_form_factors(up, sources, full.data());
  int first = -1;  // 10 consecutive sources with non-zero factors
  for (int j = 0, run = 0; j < n && first < 0; ++j) {
    run = full[size_t(j)] > 0.0 ? run + 1 : 0;
    if (run == 10) first = j - 9;
  }
  ASSERT_GE(first, 0);
  std::fill(facing.begin(), facing.end(), Facing::Toward);
  std::fill(facing.begin() + first, facing.begin() + first + 10, Facing::Away);
  lambert_form_factors_facing(up, sources, facing.data(), restricted.data());
  for (int j = first; j < first + 10; ++j) EXPECT_EQ(restricted[size_t(j)], 0.0);
  std::fill(facing.begin() + first + 3, facing.begin() + first + 10, Facing::Toward);
  lambert_form_factors_facing(up, sources, facing.data(), restricted.data());
  for (int j = first; j < first + 10; ++j) EXPECT_EQ(restricted[size_t(j)], full[size_t(j)]);
}
