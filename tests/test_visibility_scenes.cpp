// Visibility in whole scenes: shaft culling, the invariants of the filled matrix, the Cornell box
// in exact and ray modes, and coplanar neighbours.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <numeric>

#include "formfactors/formfactors.h"
#include "kernels/lambert.h"
#include "pipeline/solve.h"
#include "scene_builders.h"
#include "validation/bench.h"
#include "visibility/visibility.h"
#include "visibility_configs.h"

using namespace photometria;

namespace {

Scene room_with_table() {
  Scene room = builders::unit_cube(0.5, 1.0);
  builders::add_box(room, Vec3(0.3, 0.3, 0.4), Vec3(0.7, 0.7, 0.45));
  return room;
}

FormFactorMatrix fill(const PatchMesh& mesh, const Visibility* vis, FillStats& stats, int quadrature = 1) {
  FillOptions opt;
  opt.quadrature = quadrature;
  opt.visibility = vis;
  return fill_form_factors(mesh, opt, stats).to_dense();
}

std::string mesh_path(const std::string& name) { return std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/" + name; }

}  // namespace

// Every pair the culler leaves out really is unoccluded: exact visibility against every face of
// the scene gives the unoccluded factor. And pairs it keeps include all the occluded ones.
TEST(VisibilityScenes, CulledShaftsAreReallyEmpty) {
  const Scene room = room_with_table();
  const PatchMesh mesh = subdivide(room, {0.34, 0.0});
  const ShaftCuller culler(room);
  std::vector<int> everything(culler.occluder_count()), occ;
  std::iota(everything.begin(), everything.end(), 0);
  const double tol = plane_tolerance(mesh);
  int culled = 0, kept = 0, occluded_kept = 0;
  Vec3 a[4], b[4];
  for (int i = 0; i < mesh.size(); ++i)
    for (int j = 0; j < mesh.size(); ++j) {
      if (i == j || facing_away(mesh, i, j, tol)) continue;
      mesh.polygon(i, a);
      mesh.polygon(j, b);
      culler.occluders(a, mesh.patches[i].corner_count, b, mesh.patches[j].corner_count, occ);
      const Receiver x{mesh.patches[i].centroid, mesh.patches[i].normal};
      const double f0 = lambert_form_factor(x, b, mesh.patches[j].corner_count);
      const double fv =
          exact_visible_form_factor(x, b, mesh.patches[j].corner_count, culler.occluder_polygons(), everything);
      if (occ.empty()) {
        ++culled;
        EXPECT_NEAR(fv, f0, 1e-12) << i << " " << j;
      } else {
        ++kept;
        occluded_kept += fv < f0 - 1e-12;
        // The kept list is enough: clipping by it alone gives the same as by every face.
        EXPECT_NEAR(exact_visible_form_factor(x, b, mesh.patches[j].corner_count, culler.occluder_polygons(), occ), fv,
                    1e-13);
      }
    }
  EXPECT_GT(culled, kept);  // most shafts of a room with one small table are empty
  EXPECT_GT(occluded_kept, 0);
}

// The same on a scene with a deep face tree: 6 × 6 small boxes on the floor (222 faces). The
// candidates from the AABB tree are enough for exact clipping to match clipping by every face.
TEST(VisibilityScenes, FaceTreeFindsEveryOccluderInABusyRoom) {
  Scene room = builders::unit_cube(0.5, 1.0);
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b)
      builders::add_box(room, Vec3(0.05 + a / 6.5, 0.05 + b / 6.5, 0.0),
                        Vec3(0.12 + a / 6.5, 0.12 + b / 6.5, 0.1 + 0.05 * ((a + b) % 3)));
  const PatchMesh mesh = subdivide(room, {0.34, 0.0});
  const ShaftCuller culler(room);
  ASSERT_EQ(culler.occluder_count(), 222);
  std::vector<int> everything(culler.occluder_count()), occ;
  std::iota(everything.begin(), everything.end(), 0);
  const double tol = plane_tolerance(mesh);
  int checked = 0, culled = 0;
  Vec3 a[4], b[4];
  for (int i = 0; i < mesh.size(); i += 3)
    for (int j = 1; j < mesh.size(); j += 7) {
      if (i == j || facing_away(mesh, i, j, tol)) continue;
      mesh.polygon(i, a);
      mesh.polygon(j, b);
      culler.occluders(a, mesh.patches[i].corner_count, b, mesh.patches[j].corner_count, occ);
      EXPECT_LT(occ.size(), everything.size());
      const Receiver x{mesh.patches[i].centroid, mesh.patches[i].normal};
      const double fv =
          exact_visible_form_factor(x, b, mesh.patches[j].corner_count, culler.occluder_polygons(), everything);
      EXPECT_NEAR(exact_visible_form_factor(x, b, mesh.patches[j].corner_count, culler.occluder_polygons(), occ), fv,
                  1e-13)
          << i << " " << j;
      ++checked;
      culled += occ.empty();
    }
  EXPECT_GT(checked, 200);
  EXPECT_GT(culled, 0);
}

TEST(VisibilityScenes, ConvexRoomIsCulledEntirely) {
  const Scene cube = builders::unit_cube();
  const PatchMesh mesh = subdivide(cube, {0.2, 0.0});
  for (VisibilityMethod m : {VisibilityMethod::Rays, VisibilityMethod::Exact}) {
    const Visibility vis(cube, m);
    FillStats stats;
    fill(mesh, &vis, stats);
    EXPECT_GT(stats.pairs_tested, 0);
    EXPECT_EQ(stats.pairs_culled, stats.pairs_tested);
    EXPECT_EQ(stats.rays_cast, 0);
  }
}

// The invariants, pair by pair, in both modes: 0 <= F <= 1, F <= F unoccluded, rows <= 1 and = 1
// in this closed room, reciprocity to the quadrature error (same as without occluders).
TEST(VisibilityScenes, InvariantsHoldInAClosedRoomWithATable) {
  const Scene room = room_with_table();
  const PatchMesh mesh = subdivide(room, {0.25, 0.0});
  FillStats s0;
  const FormFactorMatrix F0 = fill(mesh, nullptr, s0, 3);
  const FormFactorChecks c0 = check_form_factors(mesh, F0);
  for (VisibilityMethod m : {VisibilityMethod::Exact, VisibilityMethod::Rays}) {
    const Visibility vis(room, m);
    FillStats stats;
    const FormFactorMatrix F = fill(mesh, &vis, stats, 3);
    const FormFactorChecks c = check_form_factors(mesh, F);
    EXPECT_EQ(stats.above_unoccluded, 0);
    EXPECT_GT(stats.pairs_occluded, 0);
    EXPECT_GE(c.min_entry, 0.0);
    EXPECT_LE(c.max_entry, 1.0);
    EXPECT_TRUE((F.array() <= F0.array()).all());
    EXPECT_LE(c.max_row_sum, 1.0 + 1e-12);
    if (m == VisibilityMethod::Exact) {
      EXPECT_LE(stats.max_point_row_sum, 1.0 + 1e-12);
      // Closed: every point's hemisphere is tiled by the visible fragments. The patches under
      // the table's legs do not exist here (a slab on no legs), so every row is 1.
      EXPECT_GE(c.min_row_sum, 1.0 - 1e-12);
      EXPECT_LE(c.reciprocity_error, 2.0 * c0.reciprocity_error + 1e-3);
    } else {
      EXPECT_GE(c.min_row_sum, 1.0 - 0.01);  // rays: within their error
    }
  }
}

// Cornell box: the blocks shadow the floor; exact and ray modes agree within the rays' error.
TEST(VisibilityScenes, CornellBoxExactAndRaysAgree) {
  const Scene box = load_scene(mesh_path("cornell_box.obj"));
  const PatchMesh mesh = subdivide(box, {0.7, 0.0});
  const Visibility exact(box, VisibilityMethod::Exact), rays(box, VisibilityMethod::Rays);
  FillStats se, sr, s0;
  const FormFactorMatrix Fe = fill(mesh, &exact, se), Fr = fill(mesh, &rays, sr), F0 = fill(mesh, nullptr, s0);
  // Adaptive sampling (the default) casts at least 8² rays, and more while the pair is partly hidden.
  ASSERT_EQ(FillOptions{}.rays, kAdaptiveRays);
  const int k = 64;
  double worst = 0.0;
  for (int i = 0; i < mesh.size(); ++i)
    for (int j = 0; j < mesh.size(); ++j) {
      // Stated error: a binomial bound on the visible fraction, σ <= 0.5/√K (jittered is better).
      const double sigma = 0.5 / std::sqrt(double(k)) * F0(i, j);
      if (sigma > 0) worst = std::max(worst, std::abs(Fr(i, j) - Fe(i, j)) / sigma);
      if (sigma > 0 && std::abs(Fr(i, j) - Fe(i, j)) / sigma > 5)
        std::printf("pair %d (face %d %s) -> %d (face %d %s): F0 %.6g exact %.6g rays %.6g\n", i, mesh.patches[i].face,
                    box.materials[box.faces[mesh.patches[i].face].material].name.c_str(), j, mesh.patches[j].face,
                    box.materials[box.faces[mesh.patches[j].face].material].name.c_str(), F0(i, j), Fe(i, j), Fr(i, j));
    }
  EXPECT_LT(worst, 5.0);
  EXPECT_GT(se.pairs_occluded, 0);
  EXPECT_GT(se.pairs_culled, 0);
  EXPECT_LT(se.pairs_culled, se.pairs_tested);
  // Floor patches under a block see none of the light; the radiosity solutions agree.
  int light = -1;
  for (int i = 0; i < mesh.size(); ++i)
    if (box.materials[box.faces[mesh.patches[i].face].material].name == "light") light = i;
  ASSERT_GE(light, 0);
  int dark = 0;
  for (int i = 0; i < mesh.size(); ++i) dark += F0(i, light) > 0 && Fe(i, light) == 0.0;
  EXPECT_GT(dark, 0);
  // Cast shadows, not only the patches hidden under a block: floor patches beside the blocks see
  // part of the light (0 < exact < unoccluded by more than the ray error), and there the ray
  // estimate is partial too.
  int partial = 0, partial_rays = 0;
  for (int i = 0; i < mesh.size(); ++i) {
    if (box.materials[box.faces[mesh.patches[i].face].material].name != "floor") continue;
    const bool shaded = Fe(i, light) > 0.0 && Fe(i, light) < 0.95 * F0(i, light);
    partial += shaded;
    partial_rays += shaded && Fr(i, light) > 0.0 && Fr(i, light) < 0.97 * F0(i, light);
  }
  EXPECT_GT(partial, 0);
  EXPECT_EQ(partial_rays, partial);
  const FormFactorChecks ce = check_form_factors(mesh, Fe);
  EXPECT_LE(ce.max_row_sum, 1.0 + 1e-12);
  EXPECT_LE(check_form_factors(mesh, Fr).max_row_sum, 1.0 + 1e-12);
}

TEST(VisibilityScenes, CornellBoxEnergyBalanceClosesInExactMode) {
  const Scene box = load_scene(mesh_path("cornell_box.obj"));
  SolveOptions opt;
  opt.patching.max_edge = 0.5;
  opt.quadrature = 2;
  opt.visibility = VisibilityMode::Exact;
  opt.solver.tolerance = 1e-12;
  const SolveResult r = solve_scene(box, opt);
  EXPECT_EQ(r.summary.visibility_mode, "exact");
  EXPECT_EQ(r.summary.fill.above_unoccluded, 0);
  EXPECT_LE(r.summary.checks.max_row_sum, 1.0 + 1e-12);
  EXPECT_LT(r.summary.energy.relative_imbalance, 0.05);
  EXPECT_GT(r.summary.vertex_pairs_culled, 0);
}

// Two coplanar patches sharing an edge see each other with F = 0, and a wall made of two coplanar
// faces meeting at an edge lets nothing through the seam, in either mode.
TEST(VisibilityScenes, CoplanarNeighboursAndSeamsDoNotLeak) {
  using vis_configs::Polygon;
  // A unit room split at x = 0.5 by a two-sided wall of two faces sharing the edge y = 0.5.
  std::vector<Polygon> faces = {
      vis_configs::rect_poly(0, 1, 0, 1, 0, false),  // floor, facing up
      vis_configs::rect_poly(0, 1, 0, 1, 1),         // ceiling, facing down
      vis_configs::wall_x(0.5, 0, 0.5, 0, 1),        // the wall, lower half in y
      vis_configs::wall_x(0.5, 0.5, 1, 0, 1),        // upper half: coplanar, adjacent
  };
  const Scene scene = vis_configs::scene_of(faces);
  const PatchMesh mesh = subdivide(scene, {0.25, 0.0});
  for (VisibilityMethod m : {VisibilityMethod::Exact, VisibilityMethod::Rays}) {
    const Visibility vis(scene, m);
    FillStats stats;
    const FormFactorMatrix F = fill(mesh, &vis, stats);
    for (int i = 0; i < mesh.size(); ++i)
      for (int j = 0; j < mesh.size(); ++j) {
        const Vec3 ci = mesh.patches[i].centroid, cj = mesh.patches[j].centroid;
        const bool wall_i = mesh.patches[i].face >= 2, wall_j = mesh.patches[j].face >= 2;
        if (wall_i && wall_j) {
          EXPECT_EQ(F(i, j), 0.0);  // coplanar wall patches
        }
        if (!wall_i && !wall_j && (ci.x() - 0.5) * (cj.x() - 0.5) < 0) { EXPECT_EQ(F(i, j), 0.0) << i << " " << j; }
      }
    // A floor point level with the seam (y = 0.5): segments to the ceiling beyond the wall aim
    // straight at the seam line; none gets through.
    const Receiver x{Vec3(0.3, 0.5, 0), Vec3::UnitZ()};
    const Polygon beyond = vis_configs::rect_poly(0.5, 1, 0.25, 0.75, 1);
    std::vector<int> occ;
    vis.culler().occluders(&x.point, 1, beyond.data(), 4, occ);
    ASSERT_FALSE(occ.empty());
    RayTally cast;
    const double f0 = lambert_form_factor(x, beyond);
    EXPECT_GT(f0, 0.0);
    EXPECT_EQ(vis.point_to_patch(x, beyond.data(), 4, -Vec3::UnitZ(), f0, occ, 4096, 7, cast), 0.0);
  }
}

// Compares GroupedShaftCuller with each pair's own shaft (ShaftCuller::occluders) for receivers
// i = 0, i_step, ... (as patch and as centroid point) and sources j = j_first + k·j_step facing
// them: the grouped list must be a subset that gives the same exact visible factor.
struct GroupedCheck {
  int checked = 0, culled_pair = 0, culled_grouped = 0, occluded = 0;
};
static GroupedCheck check_grouped_culler(const ShaftCuller& culler, const PatchMesh& mesh, GroupedShaftCuller& grouped,
                                         int i_step, int j_step, bool j_first_by_row) {
  GroupedCheck c;
  std::vector<int> everything(culler.occluder_count()), occ, occ_grouped;
  std::iota(everything.begin(), everything.end(), 0);
  const double tol = plane_tolerance(mesh);
  Vec3 a[4], b[4];
  for (int i = 0; i < mesh.size(); i += i_step) {
    mesh.polygon(i, a);
    const Patch& pi = mesh.patches[i];
    for (bool point : {false, true}) {
      const Vec3* receiver = point ? &pi.centroid : a;
      const int nr = point ? 1 : pi.corner_count;
      grouped.set_receiver(receiver, nr);
      for (int j = j_first_by_row ? i % j_step : 0; j < mesh.size(); j += j_step) {
        if (i == j || facing_away(mesh, i, j, tol)) continue;
        mesh.polygon(j, b);
        const int nb = mesh.patches[j].corner_count;
        culler.occluders(receiver, nr, b, nb, occ);
        grouped.occluders(j, b, nb, occ_grouped);
        EXPECT_TRUE(std::includes(occ.begin(), occ.end(), occ_grouped.begin(), occ_grouped.end())) << i << " " << j;
        const Receiver x{pi.centroid, pi.normal};
        const double fv = exact_visible_form_factor(x, b, nb, culler.occluder_polygons(), everything);
        EXPECT_NEAR(exact_visible_form_factor(x, b, nb, culler.occluder_polygons(), occ_grouped), fv, 1e-13)
            << i << " " << j;
        c.occluded += fv < lambert_form_factor(x, b, nb) - 1e-12;
        c.culled_pair += occ.empty();
        c.culled_grouped += occ_grouped.empty();
        ++c.checked;
      }
    }
  }
  return c;
}

// The hierarchical culler (face, tile of patches, patch) gives a subset of the pair's own
// occluders that is still enough for exact clipping, for patch receivers and for point
// receivers, on a busy room whose floor has many tiles. It culls at least as much as the pair test.
// For tiles of 1, 16 (the patch receivers') and 64 (PointVisibility's) patches, each tile holding
// at most that many patches of one face.
TEST(VisibilityScenes, GroupedCullerKeepsEveryOccluderItNeeds) {
  Scene room = builders::unit_cube(0.5, 1.0);
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b)
      builders::add_box(room, Vec3(0.08 + a / 4.5, 0.08 + b / 4.5, 0.0),
                        Vec3(0.18 + a / 4.5, 0.18 + b / 4.5, 0.1 + 0.1 * ((a + b) % 3)));
  const PatchMesh mesh = subdivide(room, {0.06, 0.0});
  const ShaftCuller culler(room);
  EXPECT_THROW(GroupedShaftCuller(culler, mesh, 0), std::invalid_argument);
  int previous_tiles = mesh.size() + 1;
  for (const int tile_patches : {1, kTilePatches, kPointTilePatches}) {
    SCOPED_TRACE("tiles of " + std::to_string(tile_patches));
    GroupedShaftCuller grouped(culler, mesh, tile_patches);
    std::vector<int> per_tile(size_t(grouped.tile_count()), 0);
    for (int j = 0; j < mesh.size(); ++j) {
      const int t = grouped.tile_of(j);
      ASSERT_GE(t, 0);
      EXPECT_EQ(grouped.tile_face(t), mesh.patches[j].face);
      ++per_tile[size_t(t)];
    }
    EXPECT_LE(*std::max_element(per_tile.begin(), per_tile.end()), tile_patches);
    EXPECT_LT(grouped.tile_count(), previous_tiles);
    previous_tiles = grouped.tile_count();
    const GroupedCheck c = check_grouped_culler(culler, mesh, grouped, 37, 5, true);
    EXPECT_GT(c.checked, 5000);
    EXPECT_GT(c.occluded, 100);
    EXPECT_GE(c.culled_grouped, c.culled_pair);
  }
}

// Convex solids (the furniture's boxes) cast their shadows with the faces toward the receiver
// only, or as one volume each: dropping the rest, or clipping by the solid's volume, changes no
// exact visible factor, also for receivers on the floor under
// a leg (on the solid's surface: nothing dropped) and on the furniture itself. The room (normals
// inward) is not a convex solid.
TEST(VisibilityScenes, ConvexSolidsCastShadowsWithTheirFrontFacesOnly) {
  const Scene room = validation::bench_room_scene();
  const ShaftCuller culler(room);
  EXPECT_EQ(culler.convex_solid_count(), static_cast<int>(validation::bench_room_furniture().size()));
  const PatchMesh mesh = subdivide(room, {0.3, 0.0});
  std::vector<int> everything(culler.occluder_count());
  std::iota(everything.begin(), everything.end(), 0);
  std::vector<int> kept;
  const double tol = plane_tolerance(mesh);
  int checked = 0, reduced = 0, occluded = 0;
  Vec3 b[4];
  for (int i = 0; i < mesh.size(); i += 7) {
    const Patch& pi = mesh.patches[i];
    const Receiver x{pi.centroid, pi.normal};
    kept = everything;
    culler.drop_hidden_occluders(x.point, kept);
    reduced += kept.size() < everything.size();
    for (int j = i % 11; j < mesh.size(); j += 11) {
      if (i == j || facing_away(mesh, i, j, tol)) continue;
      mesh.polygon(j, b);
      const int nb = mesh.patches[j].corner_count;
      const double all = exact_visible_form_factor(x, b, nb, culler.occluder_polygons(), everything);
      EXPECT_NEAR(exact_visible_form_factor(x, b, nb, culler.occluder_polygons(), kept), all, 1e-13) << i << " " << j;
      // One shadow volume per solid (its silhouette and front faces) hides the same.
      EXPECT_NEAR(
          exact_visible_form_factor(x, b, nb, culler.occluder_polygons(), kept, &culler.occluder_normals(), &culler),
          all, 1e-13)
          << i << " " << j;
      occluded += all < lambert_form_factor(x, b, nb) - 1e-12;
      ++checked;
    }
  }
  EXPECT_GT(checked, 2000);
  EXPECT_GT(occluded, 200);
  EXPECT_GT(reduced, 50);
  // A floor point under a table leg is on the leg's surface: every face of the leg stays.
  const validation::BenchBox leg = validation::bench_room_furniture()[1];
  const Vec3 under_leg(0.5 * (leg.lo.x() + leg.hi.x()), 0.5 * (leg.lo.y() + leg.hi.y()), 0.0);
  kept = everything;
  culler.drop_hidden_occluders(under_leg, kept);
  const int first_leg_face = 6 + 1 + 6 * 1;  // room, light, table top, then the leg (bench.h)
  for (int f = first_leg_face; f < first_leg_face + 6; ++f)
    EXPECT_TRUE(std::find(kept.begin(), kept.end(), f) != kept.end()) << f;
  EXPECT_LT(kept.size(), everything.size());  // the other solids' back faces do go
}

// PointVisibility (one clipping per tile of patches) gives exact_visible_form_factor against
// every face, for patch centroids and for corner points (with their approach direction), in the
// Cornell box (rotated blocks) and the bench room (furniture on the floor), with either culling
// of the tiles (cones from the point, or the face–tile tree).
TEST(VisibilityScenes, PointVisibilityPerTileEqualsClippingEachPatch) {
  struct Case {
    Scene scene;
    double edge;
    int step;
  };
  std::vector<Case> cases;
  cases.push_back({load_scene(mesh_path("cornell_box.obj")), 0.15, 40});
  cases.push_back({validation::bench_room_scene(), 0.3, 26});
  // A scanned object (a closed solid that is not convex) in a room: its back faces are dropped
  // for the points outside it, on it (centroids, by their face) and at its convex vertices.
  Scene scanned = builders::unit_cube();
  builders::add_bumpy_sphere(scanned, {0.45, 0.5, 0.35}, 0.25, 8, 10, 0.2);
  cases.push_back({scanned, 0.25, 4});
  for (const PointCulling culling : {PointCulling::Cones, PointCulling::Tree}) {
    for (const Case& c : cases) {
      SCOPED_TRACE(culling == PointCulling::Cones ? "cone culling" : "tree culling");
      const PatchMesh mesh = subdivide(c.scene, {c.edge, 0.0});
      const Visibility vis(c.scene, VisibilityMethod::Exact);
      PointVisibility from_point(vis, mesh, culling);
      std::vector<int> everything(vis.culler().occluder_count());
      std::iota(everything.begin(), everything.end(), 0);
      const double tol = plane_tolerance(mesh);
      int checked = 0, shadowed = 0, partly = 0, tile_hidden = 0, tile_clear = 0;
      RayTally rays;
      Vec3 b[4];
      // The tree culling (the default for scenes of many faces) on every third receiver of these.
      const int step = culling == PointCulling::Cones ? c.step : 3 * c.step;
      for (int i = 0; i < mesh.size(); i += step) {
        const Patch& pi = mesh.patches[i];
        for (int corner = -1; corner < pi.corner_count; ++corner) {
          // The centroid, then each corner pulled a hair toward the centroid (a gather point's approach).
          Receiver x{pi.centroid, pi.normal};
          if (corner >= 0) {
            const Vec3 p = mesh.points[size_t(pi.corners[size_t(corner)])];
            x = Receiver{p, pi.normal, (pi.centroid - p).normalized()};
          }
          from_point.set_receiver(x, corner < 0 ? pi.face : -1);  // a centroid lies inside its face
          for (int j = 0; j < mesh.size(); ++j) {
            if (i == j) continue;
            mesh.polygon(j, b);
            const Patch& pj = mesh.patches[j];
            double above = -1.0;
            for (int k = 0; k < pj.corner_count; ++k) above = std::max(above, x.normal.dot(b[k] - x.point));
            if (above <= tol || pj.normal.dot(x.point - pj.centroid) <= tol) continue;
            const double f0 = lambert_form_factor(x, b, pj.corner_count);
            if (!(f0 > 0.0)) continue;
            const double want = std::min(
                f0, exact_visible_form_factor(x, b, pj.corner_count, vis.culler().occluder_polygons(), everything));
            bool unshadowed = false;
            // Asked before visible() on every other receiver, after it on the others: the answer
            // must not depend on whether the tile was clipped already.
            using TileShadow = PointVisibility::TileShadow;
            const TileShadow before = (i / step) % 2 ? from_point.tile_shadow(j) : TileShadow::Unknown;
            const double got = from_point.visible(j, b, pj.corner_count, pj.normal, f0, 0, 0, rays, unshadowed);
            ASSERT_NEAR(got, want, 1e-13 + 1e-12 * f0) << "receiver " << i << " corner " << corner << " patch " << j;
            const TileShadow tile = (i / step) % 2 ? before : from_point.tile_shadow(j);
            if (tile == TileShadow::None) {
              ASSERT_EQ(got, f0) << "receiver " << i << " corner " << corner << " patch " << j;
              ASSERT_TRUE(unshadowed);
              ++tile_clear;
            } else if (tile == TileShadow::Full) {
              ASSERT_EQ(got, 0.0) << "receiver " << i << " corner " << corner << " patch " << j;
              ASSERT_FALSE(unshadowed);
              ++tile_hidden;
            }
            if (unshadowed) { EXPECT_NEAR(want, f0, 1e-13 + 1e-12 * f0) << i << " " << j; }
            shadowed += want == 0.0;
            partly += want > 0.0 && want < f0 * (1 - 1e-9);
            ++checked;
          }
        }
      }
      std::printf("%s culling, %d patches: %d pairs checked, %d shadowed, %d partly, tile clear %d, hidden %d\n",
                  culling == PointCulling::Cones ? "cone" : "tree", mesh.size(), checked, shadowed, partly, tile_clear,
                  tile_hidden);
      EXPECT_GT(checked, culling == PointCulling::Cones ? 20000 : 6000);
      EXPECT_GT(shadowed, 30);
      EXPECT_GT(partly, 30);
      EXPECT_GT(tile_clear, checked / 10);
      EXPECT_GT(tile_hidden, 0);
      EXPECT_EQ(rays.cast, 0);
    }
  }
}

// A receiver at the same point as the previous one with another normal (a gather point split at
// a crease) reuses the point's culling and clipping: its visible factors are those of a
// PointVisibility that starts afresh at that receiver, bit for bit.
// tile_shadow keeps its last tile's answer; a new receiver point must forget it. Asked of one
// patch from one point and then from another, it must answer as a fresh PointVisibility at the
// second point does (the pairs where the two points' answers differ are what can fail).
TEST(VisibilityScenes, PointVisibilityTileShadowIsForgottenAtANewPoint) {
  const Scene scene = validation::bench_room_scene();
  const PatchMesh mesh = subdivide(scene, {0.3, 0.0});
  const Visibility vis(scene, VisibilityMethod::Exact);
  std::vector<Receiver> points;
  for (int i = 0; i < mesh.size(); i += 29)
    points.push_back(Receiver{mesh.patches[i].centroid, mesh.patches[i].normal});
  ASSERT_GE(points.size(), 10u);
  using TileShadow = PointVisibility::TileShadow;
  PointVisibility reused(vis, mesh);
  int compared = 0, changed = 0;
  for (size_t r = 1; r < points.size(); ++r) {
    PointVisibility fresh(vis, mesh);
    fresh.set_receiver(points[r]);
    for (int j = 0; j < mesh.size(); ++j) {
      reused.set_receiver(points[r - 1]);
      const TileShadow before = reused.tile_shadow(j);
      reused.set_receiver(points[r]);
      const TileShadow want = fresh.tile_shadow(j);
      ASSERT_EQ(reused.tile_shadow(j), want) << "patch " << j << " receiver " << r;
      changed += before != want;
      ++compared;
    }
  }
  EXPECT_GT(compared, 1000);
  EXPECT_GT(changed, 50);
}

TEST(VisibilityScenes, PointVisibilityAtTheSamePointWithAnotherNormal) {
  const Scene scene = validation::bench_room_scene();
  const PatchMesh mesh = subdivide(scene, {0.3, 0.0});
  const Visibility vis(scene, VisibilityMethod::Exact);
  // Corners shared by patches of different normals: the furniture's and the room's edges.
  std::vector<std::pair<Receiver, Receiver>> creases;
  for (int i = 0; i < mesh.size() && creases.size() < 40; ++i)
    for (int k = 0; k < mesh.patches[i].corner_count; ++k)
      for (int j = 0; j < i; ++j) {
        const Patch &pi = mesh.patches[i], &pj = mesh.patches[j];
        const int v = pi.corners[size_t(k)];
        const bool shares = std::find(pj.corners.begin(), pj.corners.begin() + pj.corner_count, v) !=
                            pj.corners.begin() + pj.corner_count;
        if (!shares || pi.normal.dot(pj.normal) > 0.5) continue;
        const Vec3 p = mesh.points[size_t(v)];
        creases.push_back({Receiver{p, pj.normal, (pj.centroid - p).normalized()},
                           Receiver{p, pi.normal, (pi.centroid - p).normalized()}});
        break;
      }
  ASSERT_GE(creases.size(), 20u);
  PointVisibility reused(vis, mesh);
  RayTally rays;
  int compared = 0, shadowed = 0;
  Vec3 b[4];
  for (const auto& [first, second] : creases) {
    PointVisibility fresh(vis, mesh);
    fresh.set_receiver(second);
    reused.set_receiver(first);
    for (int j = 0; j < mesh.size(); j += 2) {  // the first receiver's queries fill the caches
      mesh.polygon(j, b);
      const double f0 = lambert_form_factor(first, b, mesh.patches[j].corner_count);
      bool unshadowed = false;
      if (f0 > 0.0)
        reused.visible(j, b, mesh.patches[j].corner_count, mesh.patches[j].normal, f0, 0, 0, rays, unshadowed);
    }
    reused.set_receiver(second);
    for (int j = 0; j < mesh.size(); ++j) {
      mesh.polygon(j, b);
      const Patch& pj = mesh.patches[j];
      const double f0 = lambert_form_factor(second, b, pj.corner_count);
      if (!(f0 > 0.0)) continue;
      bool u1 = false, u2 = false;
      const double want = fresh.visible(j, b, pj.corner_count, pj.normal, f0, 0, 0, rays, u1);
      const double got = reused.visible(j, b, pj.corner_count, pj.normal, f0, 0, 0, rays, u2);
      ASSERT_EQ(got, want) << "patch " << j;
      ASSERT_EQ(u1, u2) << "patch " << j;
      EXPECT_EQ(reused.tile_shadow(j), fresh.tile_shadow(j)) << "patch " << j;
      shadowed += !u1;
      ++compared;
    }
  }
  EXPECT_GT(compared, 5000);
  EXPECT_GT(shadowed, 100);
}

// A room that arrives as many faces (every wall quad its own face): the face groups (up to
// kFaceGroupFaces faces of one occluder) cull for their faces, and what each face keeps is still a
// subset of its own shaft's occluders that gives the exact visible factor, for patch and point
// receivers. The groups must exist here (the walls are occluders of many faces) and hold faces of
// one occluder each.
TEST(VisibilityScenes, FaceGroupsKeepEveryOccluderTheirFacesNeed) {
  const Scene room = validation::bench_room_many_faces_scene(0.5);
  const PatchMesh mesh = subdivide(room, {100.0, 0.0});  // one patch per face
  ASSERT_EQ(mesh.size(), static_cast<int>(room.faces.size()));
  const ShaftCuller culler(room);
  GroupedShaftCuller grouped(culler, mesh);
  ASSERT_GT(grouped.face_group_count(), 10);
  std::vector<int> members(size_t(grouped.face_group_count()), 0), occluder(size_t(grouped.face_group_count()), -1);
  int grouped_faces = 0;
  for (int f = 0; f < culler.scene_face_count(); ++f) {
    const int g = grouped.face_group_of(f);
    if (g < 0) continue;
    ++grouped_faces;
    ++members[size_t(g)];
    if (occluder[size_t(g)] < 0) occluder[size_t(g)] = culler.occluder_of_face(f);
    EXPECT_EQ(culler.occluder_of_face(f), occluder[size_t(g)]) << "face " << f;
  }
  EXPECT_GT(grouped_faces, culler.scene_face_count() / 2);
  for (int m : members) {
    EXPECT_GE(m, 2);
    EXPECT_LE(m, kFaceGroupFaces);
  }
  const GroupedCheck c = check_grouped_culler(culler, mesh, grouped, 7, 1, false);
  EXPECT_GT(c.checked, 10000);
  EXPECT_GT(c.occluded, 100);
  EXPECT_GE(c.culled_grouped, c.culled_pair);
}
