// Contact pairs of the per-pair rule with exact visibility: a face of a box standing on a floor
// patch against that patch (a table leg on the floor quad it stands on), against the exact factor
// of perpendicular rectangles sharing part of an edge (tests/rectangle_reference.h, Howell C-14
// superposition). The box's own faces lie behind the face's plane, so they cannot block; the fill
// must see that and not fall back to the fixed rule, whose error at a shared edge is ~1e-4.
#include <gtest/gtest.h>

#include "formfactors/formfactors.h"
#include "patching/patching.h"
#include "rectangle_reference.h"
#include "scene_builders.h"
#include "visibility/visibility.h"

namespace {

using namespace photometria;

// A 0.2 m square floor patch at z = 0 facing up, with a 0.05 × 0.05 × 0.2 m box (a leg) standing on
// it at [0.05, 0.1]²; faces: 0 floor, then the box's (1 bottom, 2 top, 3 y = lo, 4 y = hi,
// 5 x = lo, 6 x = hi; builders::add_box).
Scene floor_with_leg() {
  Scene s;
  s.source = "floor_with_leg";
  s.vertices = {{0, 0, 0}, {0.2, 0, 0}, {0.2, 0.2, 0}, {0, 0.2, 0}};
  s.faces.push_back({{0, 1, 2, 3}, 0, 0, 0});
  Material m;
  m.name = "grey";
  m.reflectance = Rgb::Constant(0.5);
  s.materials = {m};
  s.groups = {"room"};
  builders::add_box(s, {0.05, 0.05, 0.0}, {0.1, 0.1, 0.2});
  return s;
}

// Face x = 0.05 of the leg sees the floor strip x in [0, 0.05]: perpendicular rectangles with the
// common line x = 0.05, z = 0 (along y). A_leg F = perpendicular_af(leg y, leg z, strip y, strip x).
double exact_leg_to_floor() {
  const long double af = rect_ref::perpendicular_af(0.05L, 0.1L, 0.0L, 0.2L, 0.0L, 0.2L, 0.0L, 0.05L);
  return double(af / (0.05L * 0.2L));
}

FormFactors fill_exact(const Scene& scene, PatchMesh& mesh) {
  mesh = subdivide(scene, {});
  const Visibility vis(scene, VisibilityMethod::Exact);
  FillOptions o;
  o.tolerance = 1e-7;
  o.quadrature = 6;
  o.visibility = &vis;
  FillStats stats;
  return fill_form_factors(mesh, o, stats);
}

int patch_of_face(const PatchMesh& mesh, int face) {
  for (int k = 0; k < mesh.size(); ++k)
    if (mesh.patches[size_t(k)].face == face) return k;
  return -1;
}

// F(leg face x = 0.05 -> floor patch) of the scene, filled with exact visibility.
double leg_to_floor(const Scene& scene) {
  PatchMesh mesh;
  const FormFactors F = fill_exact(scene, mesh);
  return F(patch_of_face(mesh, 5), patch_of_face(mesh, 0));
}

TEST(ContactPairs, LegFaceToTheFloorPatchItStandsOn) {
  PatchMesh mesh;
  const FormFactors F = fill_exact(floor_with_leg(), mesh);
  const int leg = patch_of_face(mesh, 5), floor = patch_of_face(mesh, 0);
  ASSERT_GE(leg, 0);
  ASSERT_GE(floor, 0);
  const double exact = exact_leg_to_floor();
  EXPECT_NEAR(F(leg, floor), exact, 1e-7 * exact);
  // And from the floor's side, by reciprocity of the exact values.
  const double exact_back = exact * 0.05 * 0.2 / (0.2 * 0.2);
  EXPECT_NEAR(F(floor, leg), exact_back, 1e-7 * exact_back);
}

TEST(ContactPairs, ThirdFaceBehindTheLegFaceChangesNothing) {
  // A second leg on the same floor patch, behind the first leg's face x = 0.05: it lies in the shaft
  // of the whole pair but not between the parts that exchange light.
  Scene s = floor_with_leg();
  builders::add_box(s, {0.13, 0.02, 0.0}, {0.17, 0.18, 0.1});
  const double exact = exact_leg_to_floor();
  EXPECT_NEAR(leg_to_floor(s), exact, 1e-7 * exact);
}

TEST(ContactPairs, ThirdFaceInFrontStillBlocks) {
  // A panel standing in front of the leg face (x = 0.02, across the whole strip, 0.05 m high)
  // hides part of the strip: the factor must drop below the unblocked one.
  Scene s = floor_with_leg();
  builders::add_box(s, {0.02, 0.0, 0.0}, {0.025, 0.2, 0.05});
  const double f = leg_to_floor(s);
  EXPECT_LT(f, 0.99 * exact_leg_to_floor());
  EXPECT_GT(f, 0.0);
}

}  // namespace
