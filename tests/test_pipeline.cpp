// The pipeline folder (src/pipeline): the memory estimate before patching, the refusal of a
// run that cannot fit before anything grows with the patch count, and the text summary.
#include <gtest/gtest.h>

#include <string>

#include "patching/patching.h"
#include "pipeline/memory.h"
#include "pipeline/report.h"
#include "pipeline/solve.h"
#include "scene/scene.h"
#include "scene_builders.h"
#include "util/error.h"

using namespace photometria;

namespace {

Scene shipped(const std::string& name) { return load_scene(std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/" + name); }

void expect_same_estimate(const Scene& scene, const PatchingOptions& o) {
  const PatchMesh mesh = subdivide(scene, o);
  const MemoryEstimate after = estimate_memory(mesh, 7);
  const MemoryEstimate before = estimate_memory(scene, count_patches(scene, o), 7);
  EXPECT_EQ(before.patches, after.patches);
  EXPECT_EQ(before.pairs_total, after.pairs_total);
  EXPECT_EQ(before.nonzero_pairs, after.nonzero_pairs) << scene.source << " max_edge " << o.max_edge;
  EXPECT_EQ(before.dense_bytes, after.dense_bytes);
  EXPECT_EQ(before.sparse_bytes, after.sparse_bytes);
}

}  // namespace

// The estimate from the counts is the estimate of the mesh: every pair tested (N ≤ 128) and
// sampled (quads and triangles, occluder-only faces, the shipped scenes).
TEST(PipelineMemory, EstimateBeforePatchingIsTheMeshEstimate) {
  expect_same_estimate(builders::unit_cube(), {0.5, 0.0});  // 24 patches: every pair
  expect_same_estimate(builders::unit_cube(), {0.05, 0.0});
  expect_same_estimate(shipped("cornell_box.obj"), {0.0, 0.0});
  expect_same_estimate(shipped("cornell_box.obj"), {0.05, 0.0});
  expect_same_estimate(shipped("room_with_table.obj"), {0.15, 0.0});
  expect_same_estimate(shipped("room_with_table.obj"), {0.0, 0.01});
}

// Beyond what a mesh can index, the estimate comes from the count alone and is astronomical.
TEST(PipelineMemory, UnindexableCountsEstimateFromTheCount) {
  const Scene cube = builders::unit_cube();
  const PatchGrid g = count_patches(cube, {1e-6, 0.0});
  const MemoryEstimate e = estimate_memory(cube, g);
  EXPECT_GE(e.dense_bytes, 8.0 * 6e12 * 6e12);
  EXPECT_GE(e.sparse_bytes, e.dense_bytes);
  EXPECT_EQ(format_patch_count(6e12), "6,000,000,000,000");
  EXPECT_EQ(format_patch_count(2.5e20), "2.5e+20");
}

// solve_scene refuses a patch count that cannot fit before patching: with --max-edge 1e-5 the
// cube would have 6e10 patches (patching alone would need terabytes); the refusal is a
// BadInput naming the count and the fix.
TEST(PipelineMemory, SolveRefusesAHugePatchCountBeforePatching) {
  SolveOptions o;
  o.patching.max_edge = 1e-5;
  try {
    solve_scene(builders::unit_cube(), o);
    FAIL() << "no refusal";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    const std::string m = e.what();
    EXPECT_NE(m.find("60,000,000,000 patches"), std::string::npos) << m;
    EXPECT_NE(m.find("raise --max-edge"), std::string::npos) << m;
  }
  // The same count, refused against --max-memory too (a limit below what patching needs).
  o.patching.max_edge = 0.01;  // 60,000 patches: 29 GB dense double, 14 GB float
  o.max_memory_bytes = 64.0 * 1048576;
  EXPECT_THROW(solve_scene(builders::unit_cube(), o), Error);
}

// The text summary names what the method did: the dense method its matrix (pairs, factors,
// storage, memory estimate), the hierarchical one its hierarchy and the memory limit only; it
// fills no matrix, so rows of a dense fill would be zeros that look like results.
TEST(PipelineReport, SummaryRowsFollowTheMethod) {
  const Scene cube = builders::cube_floor_emitting(0.5);
  SolveOptions o;
  o.patching.max_edge = 0.5;
  const std::string dense = summary_table(cube, solve_scene(cube, o).summary);
  o.method = SolveMethod::Hierarchical;
  o.hierarchical_error = 0.3;
  const std::string hierarchical = summary_table(cube, solve_scene(cube, o).summary);
  for (const std::string row : {"  pairs ", "  form factors ", "  matrix ", "  memory estimate "}) {
    EXPECT_NE(dense.find(row), std::string::npos) << row << "\n" << dense;
    EXPECT_EQ(hierarchical.find(row), std::string::npos) << row << "\n" << hierarchical;
  }
  EXPECT_EQ(dense.find("  hierarchy "), std::string::npos) << dense;
  EXPECT_NE(hierarchical.find("  hierarchy "), std::string::npos) << hierarchical;
  EXPECT_NE(hierarchical.find("  memory limit "), std::string::npos) << hierarchical;
  EXPECT_NE(hierarchical.find("  energy imbalance "), std::string::npos) << hierarchical;
}
