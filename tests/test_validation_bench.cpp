// The speed benchmark (validation/bench.h, `photometria bench`): its generated scenes are valid,
// its runner returns sane rows, and the command writes its CSV. No timing is asserted.
#include "cli_run.h"
#include "validation/bench.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "geometry/polygon.h"
#include "patching/patching.h"
#include "scene/scene.h"
#include "scratch_dir.h"
#include "viewfactors/viewfactors.h"

namespace fs = std::filesystem;
namespace pm = photometria;
namespace pv = photometria::validation;

namespace {

bool inside(const pm::Vec3& p, const pm::Vec3& lo, const pm::Vec3& hi) {
  return (p.array() > lo.array()).all() && (p.array() < hi.array()).all();
}

// Every directed edge of `faces` has its reverse among them exactly once: a closed, consistently
// wound surface.
void expect_closed(const pm::Scene& s, const std::vector<int>& faces, const std::string& what) {
  std::map<std::pair<int, int>, int> edges;
  for (int f : faces) {
    const auto& v = s.faces[f].vertices;
    for (size_t k = 0; k < v.size(); ++k) ++edges[{v[k], v[(k + 1) % v.size()]}];
  }
  for (const auto& [e, count] : edges) {
    EXPECT_EQ(count, 1) << what << ": edge " << e.first << "-" << e.second << " repeated";
    const auto rev = edges.find({e.second, e.first});
    EXPECT_TRUE(rev != edges.end() && rev->second == 1) << what << ": edge " << e.first << "-" << e.second << " open";
  }
}

using cli_test::CliRun;

fs::path scratch() { return test_scratch::process_dir("photometria_bench_"); }

CliRun run(const std::string& args) { return cli_test::run_cli(args, (scratch() / "stderr.txt").string()); }

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream s(text);
  std::string line;
  while (std::getline(s, line))
    if (!line.empty()) out.push_back(line);
  return out;
}

bool finite_positive(double x) { return std::isfinite(x) && x > 0; }

}  // namespace

TEST(BenchScenes, CubeHasSixNSquaredPatchesOfPositiveArea) {
  const pm::Scene cube = pv::bench_cube_scene();
  ASSERT_EQ(cube.faces.size(), 6u);
  std::vector<int> all = {0, 1, 2, 3, 4, 5};
  expect_closed(cube, all, "cube");
  for (int n : {4, 8, 16, 32}) {
    const pm::PatchMesh mesh = pm::subdivide(cube, pv::bench_cube_patching(n));
    EXPECT_EQ(mesh.size(), 6 * n * n) << "n = " << n;
    double total = 0.0;
    for (const pm::Patch& p : mesh.patches) {
      ASSERT_GT(p.area, 0.0);
      EXPECT_NEAR(p.area, 1.0 / (n * n), 1e-12);
      total += p.area;
    }
    EXPECT_NEAR(total, 6.0, 1e-9);
  }
  int emitting = 0;
  for (const pm::Face& f : cube.faces) emitting += (cube.materials[f.material].emission > 0).any();
  EXPECT_EQ(emitting, 1);
}

TEST(BenchScenes, CubeRowSumsAreOneAtTheDefaultViewFactorAccuracy) {
  pm::ViewFactorOptions opt;  // default accuracy (1e-7 relative per pair)
  opt.patching = pv::bench_cube_patching(4);
  const pm::PatchViewFactors v = pm::compute_view_factors(pv::bench_cube_scene(), opt);
  ASSERT_EQ(v.mesh.size(), 96);
  EXPECT_EQ(v.visibility_mode, "none");  // convex
  for (int i = 0; i < v.F.rows(); ++i) EXPECT_NEAR(v.F.row_sum(i), 1.0, 1e-6) << "row " << i;
}

TEST(BenchScenes, RoomIsClosedOrientedAndItsFurnitureDoesNotIntersect) {
  const pm::Scene room = pv::bench_room_scene();
  const std::vector<pv::BenchBox> boxes = pv::bench_room_furniture();
  ASSERT_EQ(boxes.size(), 5u + 4u * 6u);  // table top + 4 legs; 4 chairs of seat, 4 legs, back
  ASSERT_EQ(room.faces.size(), 6u + 1u + 6u * boxes.size());
  const pm::Vec3 room_lo = pm::Vec3::Zero(), room_hi(pv::kBenchRoomX, pv::kBenchRoomY, pv::kBenchRoomZ);
  for (size_t f = 0; f < room.faces.size(); ++f) {
    const pm::Polygon p = room.face_polygon(static_cast<int>(f));
    ASSERT_GT(pm::polygon_area(p), 0.0) << "face " << f;
    const pm::Vec3 n = pm::polygon_normal(p), c = pm::polygon_centroid(p);
    const pm::Vec3 front = c + 1e-4 * n, back = c - 1e-4 * n;
    if (c.z() > 0) {  // (leg bottoms stand on the floor, facing it)
      EXPECT_TRUE(inside(front, room_lo, room_hi)) << "face " << f << " faces out of the room";
    }
    if (f < 6) { EXPECT_FALSE(inside(back, room_lo, room_hi)) << "wall " << f << " faces out"; }
    if (f >= 7) {  // furniture: box k = (f − 7) / 6, facing out of it
      const pv::BenchBox& b = boxes[(f - 7) / 6];
      EXPECT_TRUE(inside(back, b.lo, b.hi)) << b.name << " face " << f;
      EXPECT_FALSE(inside(front, b.lo, b.hi)) << b.name << " face " << f;
    }
  }
  EXPECT_LT(pm::polygon_normal(room.face_polygon(6)).z(), -0.999);  // the light faces down
  EXPECT_TRUE((room.materials[room.faces[6].material].emission > 0).all());
  // Closed surfaces: the room, and every box on its own.
  expect_closed(room, {0, 1, 2, 3, 4, 5}, "room");
  for (size_t k = 0; k < boxes.size(); ++k) {
    std::vector<int> faces;
    for (int m = 0; m < 6; ++m) faces.push_back(static_cast<int>(7 + 6 * k + m));
    expect_closed(room, faces, boxes[k].name);
  }
  // Inside the room, interiors pairwise disjoint (touching is fine).
  for (size_t a = 0; a < boxes.size(); ++a) {
    EXPECT_TRUE((boxes[a].lo.array() >= 0).all() && (boxes[a].hi.array() <= room_hi.array()).all()) << boxes[a].name;
    EXPECT_TRUE((boxes[a].lo.array() < boxes[a].hi.array()).all()) << boxes[a].name;
    for (size_t b = a + 1; b < boxes.size(); ++b) {
      const bool overlap =
          ((boxes[a].lo.array().max(boxes[b].lo.array())) < (boxes[a].hi.array().min(boxes[b].hi.array()))).all();
      EXPECT_FALSE(overlap) << boxes[a].name << " and " << boxes[b].name;
    }
  }
}

TEST(BenchScenes, RoomSizesGiveTheIssuesPatchCounts) {
  const pm::Scene room = pv::bench_room_scene();
  const std::vector<double> edges = pv::bench_room_edges();
  const std::vector<double> targets = {1500, 6000, 22000};
  ASSERT_EQ(edges.size(), targets.size());
  for (size_t k = 0; k < edges.size(); ++k) {
    const pm::PatchMesh mesh = pm::subdivide(room, pv::bench_room_patching(edges[k]));
    EXPECT_NEAR(mesh.size(), targets[k], 0.1 * targets[k]) << "edge " << edges[k];
    for (const pm::Patch& p : mesh.patches) ASSERT_GT(p.area, 0.0);
  }
}

// meshes/make_meshes.py --furnished-room writes the bench's room as an OBJ with y up (the bench's
// (x, y, z) is the file's (x, z, y)), so that `solve` can compare methods on the bench's scene: the
// same faces, each facing the same way, with the same materials, and the same patches.
TEST(BenchScenes, FurnishedRoomFileIsTheBenchRoom) {
  const fs::path dir = test_scratch::fresh_dir("photometria_furnished_");
  const cli_test::CliRun run = cli_test::run_command(std::string(PHOTOMETRIA_PYTHON) + " " + PHOTOMETRIA_SOURCE_DIR +
                                                         "/meshes/make_meshes.py --furnished-room " + dir.string(),
                                                     (dir / "err.txt").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const pm::Scene file = pm::load_scene((dir / "furnished_room.obj").string());
  const pm::Scene room = pv::bench_room_scene();
  ASSERT_EQ(file.faces.size(), room.faces.size());
  const auto swap_yz = [](const pm::Vec3& v) { return pm::Vec3(v.x(), v.z(), v.y()); };
  std::vector<bool> matched(file.faces.size(), false);
  for (size_t f = 0; f < room.faces.size(); ++f) {
    const pm::Polygon p = room.face_polygon(static_cast<int>(f));
    const pm::Vec3 c = swap_yz(pm::polygon_centroid(p)), n = swap_yz(pm::polygon_normal(p));
    const pm::Material& m = room.materials[size_t(room.faces[f].material)];
    int found = -1;
    for (size_t g = 0; g < file.faces.size() && found < 0; ++g) {
      const pm::Polygon q = file.face_polygon(static_cast<int>(g));
      if (!matched[g] && (pm::polygon_centroid(q) - c).norm() < 1e-9 && (pm::polygon_normal(q) - n).norm() < 1e-9 &&
          std::abs(pm::polygon_area(q) - pm::polygon_area(p)) < 1e-12)
        found = static_cast<int>(g);
    }
    ASSERT_GE(found, 0) << "bench face " << f << " (material " << m.name << ") is not in the file";
    matched[size_t(found)] = true;
    const pm::Material& k = file.materials[size_t(file.faces[size_t(found)].material)];
    EXPECT_TRUE(k.reflectance.isApprox(m.reflectance) && (k.emission - m.emission).abs().maxCoeff() < 1e-12)
        << "bench face " << f << ": " << m.name << " against " << k.name;
  }
  for (double edge : pv::bench_room_edges())
    EXPECT_EQ(pm::subdivide(file, pv::bench_room_patching(edge)).size(),
              pm::subdivide(room, pv::bench_room_patching(edge)).size())
        << "edge " << edge;
  fs::remove_all(dir);
}

TEST(BenchRunner, QuickRowsHoldFinitePositiveNumbers) {
  pv::BenchOptions opt;
  opt.quick = true;
  std::vector<std::string> started;
  int reported = 0;
  opt.on_start = [&](const std::string& label) { started.push_back(label); };
  opt.on_row = [&](const pv::BenchRow&) { ++reported; };
  const std::vector<pv::BenchRow> rows = pv::run_bench(opt);
  ASSERT_EQ(rows.size(), 4u);  // cube n=8 solve and view factors, the smallest room, the room as faces
  EXPECT_EQ(started.size(), 4u);
  EXPECT_EQ(reported, 4);
  EXPECT_EQ(rows[0].scene + rows[0].task, "cubesolve");
  EXPECT_EQ(rows[1].scene + rows[1].task, "cubeviewfactors");
  EXPECT_EQ(rows[2].scene + rows[2].task, "roomsolve");
  EXPECT_EQ(rows[3].scene + rows[3].task, "room-facesviewfactors");
  EXPECT_EQ(rows[3].patches, 245);  // one patch per face
  EXPECT_EQ(rows[0].patches, 384);
  for (const pv::BenchRow& r : rows) {
    SCOPED_TRACE(r.scene + " " + r.setting + " " + r.task);
    EXPECT_TRUE(r.skipped.empty()) << r.skipped;
    EXPECT_GT(r.patches, 0);
    EXPECT_GT(r.pairs_evaluated, 0);
    EXPECT_LE(r.pairs_evaluated, (long long)r.patches * (r.patches - 1));
    EXPECT_TRUE(finite_positive(r.pairs_per_second));
    EXPECT_TRUE(std::isfinite(r.rays_per_second) && r.rays_per_second >= 0);
    EXPECT_GE(r.rays_cast, 0);
    EXPECT_TRUE(finite_positive(r.form_factor_seconds));
    EXPECT_TRUE(finite_positive(r.total_seconds));
    EXPECT_LE(r.form_factor_seconds, r.total_seconds);
    EXPECT_TRUE(finite_positive(r.peak_memory_bytes));
    EXPECT_TRUE(finite_positive(r.estimated_bytes));
    EXPECT_TRUE(finite_positive(r.matrix_bytes));
    EXPECT_FALSE(r.matrix_storage.empty());
    EXPECT_FALSE(r.visibility.empty());
    EXPECT_GE(r.threads, 1);
    if (r.task == "solve") {
      EXPECT_TRUE(finite_positive(r.solve_seconds));
      EXPECT_TRUE(finite_positive(r.gather_seconds));
    }
    if (r.scene == "cube") {
      EXPECT_EQ(r.visibility, "none");
      EXPECT_TRUE(std::isfinite(r.max_row_sum_error));
      EXPECT_LT(r.max_row_sum_error, r.task == "viewfactors" ? 1e-6 : 0.1);
    } else {
      EXPECT_EQ(r.visibility, "exact");  // few occluders per shaft: clipping is the cheaper (choice.h)
      EXPECT_TRUE(std::isnan(r.max_row_sum_error));
    }
  }
}

TEST(BenchRunner, CasesThatWouldNotFitAreSkippedWithAReason) {
  pv::BenchOptions opt;
  opt.quick = true;
  opt.max_memory_bytes = 1024;
  const std::vector<pv::BenchRow> rows = pv::run_bench(opt);
  ASSERT_EQ(rows.size(), 4u);
  for (const pv::BenchRow& r : rows) {
    EXPECT_NE(r.skipped.find("--max-memory"), std::string::npos) << r.skipped;
    EXPECT_GT(r.patches, 0);
    EXPECT_TRUE(std::isnan(r.total_seconds));
  }
  const std::string line = pv::bench_csv_line(rows[0]);
  EXPECT_EQ(std::count(line.begin(), line.end(), ','), static_cast<long>(pv::bench_columns().size()) - 1) << line;
}

TEST(BenchCli, QuickRunWritesTheCsvAndOneJsonObjectPerRow) {
  const std::string csv = (scratch() / "bench.csv").string();
  // The cube's two rows (the runner's test above runs every quick row; here the files matter).
  const CliRun r = run("bench --quick --only \"cube n=8\" --json --threads 2 --csv " + csv);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<std::string> out = lines(r.out);
  ASSERT_EQ(out.size(), 2u) << r.out;
  for (const std::string& l : out) {
    const auto j = nlohmann::ordered_json::parse(l);
    std::vector<std::string> keys;
    for (const auto& item : j.items()) keys.push_back(item.key());
    EXPECT_EQ(keys, pv::bench_columns());
    EXPECT_GT(j["patches"].get<int>(), 0);
    EXPECT_GT(j["pairs_per_s"].get<double>(), 0);
    EXPECT_EQ(j["threads"].get<int>(), 2);
    EXPECT_EQ(j["skipped"], "");
  }
  std::ifstream in(csv);
  std::stringstream s;
  s << in.rdbuf();
  const std::vector<std::string> rows = lines(s.str());
  ASSERT_EQ(rows.size(), 1u + 2u) << s.str();
  std::string header;
  for (const std::string& c : pv::bench_columns()) header += (header.empty() ? "" : ",") + c;
  EXPECT_EQ(rows[0], header);
  EXPECT_EQ(rows[0].rfind("scene,setting,task,visibility,patches,pairs_evaluated,pairs_per_s,", 0), 0u);
  for (size_t k = 1; k < rows.size(); ++k)
    EXPECT_EQ(std::count(rows[k].begin(), rows[k].end(), ','), std::count(header.begin(), header.end(), ','));
  EXPECT_EQ(rows[1].rfind("\"cube\",\"n=8\",\"solve\",\"none\",384,", 0), 0u) << rows[1];
  for (const auto& e : fs::directory_iterator(scratch()))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
}

TEST(BenchCli, TableNamesSkippedCasesAndBadOptionsFail) {
  const CliRun r = run("bench --quick --max-memory 1k");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("pairs/s"), std::string::npos) << r.out;
  EXPECT_EQ(lines(r.out).size(), 1u + 4u) << r.out;
  EXPECT_NE(r.out.find("skipped: needs about"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("skipped"), std::string::npos) << r.err;
  EXPECT_EQ(run("bench --max-memory lots").exit_code, 1);
  const CliRun bad = run("bench --quick --csv /no/such/folder/bench.csv");
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_NE(bad.err.find("/no/such/folder"), std::string::npos) << bad.err;
}
