// End-to-end tests of the photometria command line.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cli_run.h"
#include "io/vtu.h"
#include "scratch_dir.h"

namespace fs = std::filesystem;
using photometria::VtuArray;
using photometria::VtuGrid;

namespace {

using cli_test::CliRun;

fs::path scratch() { return test_scratch::process_dir("photometria_cli_"); }

CliRun run(const std::string& args) { return cli_test::run_cli(args, (scratch() / "stderr.txt").string()); }

std::string mesh(const std::string& name) { return std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/" + name; }

const VtuArray& array(const std::vector<VtuArray>& arrays, const std::string& name) {
  for (const auto& a : arrays)
    if (a.name == name) return a;
  throw std::runtime_error("missing array " + name);
}

int count_lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

}  // namespace

TEST(Cli, SolvesTheCornellBoxIntoAVtuWithEveryArray) {
  const std::string out = (scratch() / "cornell.vtu").string();
  const CliRun r = run("solve " + mesh("cornell_box.obj") + " -o " + out + " --json --threads 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary["visibility"]["mode"], "exact");  // the blocks can occlude; small scene: exact
  EXPECT_EQ(summary["solver"]["channels"], 3);
  EXPECT_GT(summary["pairs"]["skipped_backfacing"].get<long long>(), 0);
  const VtuGrid g = photometria::read_vtu(out);
  const size_t points = g.points.size(), cells = g.cells.size();
  EXPECT_EQ(cells, summary["patches"].get<size_t>());
  for (const std::string name : {"radiosity", "irradiance"}) {
    const VtuArray& a = array(g.point_arrays, name);
    EXPECT_EQ(a.components, 3);
    EXPECT_EQ(a.values.size(), 3 * points);
    for (double v : a.values) ASSERT_TRUE(std::isfinite(v) && v >= 0) << name;
  }
  for (const std::string name : {"radiosity", "irradiance", "emission", "reflectance"}) {
    const VtuArray& a = array(g.cell_arrays, name);
    EXPECT_EQ(a.values.size(), 3 * cells) << name;
    for (double v : a.values) ASSERT_TRUE(std::isfinite(v) && v >= 0) << name;
  }
  for (const std::string name : {"area", "face", "group"}) {
    const VtuArray& a = array(g.cell_arrays, name);
    EXPECT_EQ(a.values.size(), cells) << name;
  }
  std::set<double> groups(array(g.cell_arrays, "group").values.begin(), array(g.cell_arrays, "group").values.end());
  EXPECT_GE(groups.size(), 7u);
  // The light's cells emit (17, 12, 4) W/m².
  const auto& e = array(g.cell_arrays, "emission").values;
  bool light = false;
  for (size_t c = 0; c < cells; ++c) light = light || (e[3 * c] == 17 && e[3 * c + 1] == 12 && e[3 * c + 2] == 4);
  EXPECT_TRUE(light);
}

TEST(Cli, FurnaceCubeIsUniformAndItsEnergyBalanceCloses) {
  const std::string out = (scratch() / "furnace.vtu").string();
  const CliRun r =
      run("solve " + mesh("furnace_cube.obj") + " -o " + out + " --max-edge 0.25 --tolerance 1e-12 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto s = nlohmann::json::parse(r.out);
  EXPECT_EQ(s["visibility"]["mode"], "none");
  EXPECT_NE(s["visibility"]["reason"].get<std::string>().find("convex"), std::string::npos);
  EXPECT_EQ(s["solver"]["channels"], 1);
  EXPECT_LE(s["energy_w"]["relative_imbalance"].get<double>(), 1e-6);
  const VtuGrid g = photometria::read_vtu(out);
  for (double b : array(g.cell_arrays, "radiosity").values) EXPECT_NEAR(b, 2.0, 2e-9);   // E / (1 − ρ)
  for (double b : array(g.point_arrays, "radiosity").values) EXPECT_NEAR(b, 2.0, 2e-9);  // also at corners
  EXPECT_EQ(g.points.size(), 6u * 25);  // split at the cube's creases: 5 × 5 points per wall
}

TEST(Cli, MissingFileIsAnIoErrorAndWritesNothing) {
  const std::string out = (scratch() / "missing.vtu").string();
  const CliRun r = run("solve /no/such/room.obj -o " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("/no/such/room.obj"), std::string::npos) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Cli, MalformedObjLineNamesFileAndLine) {
  const fs::path obj = scratch() / "bad.obj";
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 1 abc 0\nf 1 2 3\n";
  const std::string out = (scratch() / "bad.vtu").string();
  const CliRun r = run("solve " + obj.string() + " -o " + out + " --emission 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("bad.obj:3"), std::string::npos) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Cli, ReflectanceOfOneIsRefusedNamingTheValue) {
  const fs::path dir = scratch();
  std::ofstream(dir / "white.mtl") << "newmtl white\nKd 1.0 0.5 0.5\nKe 1 1 1\n";
  std::ofstream(dir / "white.obj") << "mtllib white.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl white\nf 1 2 3\n";
  const std::string out = (dir / "white.vtu").string();
  const CliRun r = run("solve " + (dir / "white.obj").string() + " -o " + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("white"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1"), std::string::npos) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_FALSE(fs::exists(out));
  const CliRun r2 = run("solve " + mesh("furnace_cube.obj") + " -o " + out + " --max-edge 0.5 --reflectance 1.5");
  EXPECT_EQ(r2.exit_code, 0) << "materials from the .mtl win over --reflectance: " << r2.err;
}

TEST(Cli, UnwritableOutputFailsBeforeSolving) {
  const CliRun r = run("solve " + mesh("furnace_cube.obj") + " -o /no/such/dir/out.vtu");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("/no/such/dir/out.vtu"), std::string::npos) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
}

TEST(Cli, HelpExitsZero) {
  EXPECT_EQ(run("solve --help").exit_code, 0);
  EXPECT_NE(run("--help").out.find("solve"), std::string::npos);
}

TEST(Cli, JsonSceneAppliesMaterialOverridesAndSettings) {
  const fs::path dir = scratch();
  std::ofstream(dir / "scene.json") << R"({"meshes": [{"file": ")" << mesh("two_squares.obj") << R"("}],
    "materials": {"receiver": {"reflectance": [0.25, 0.5, 0.75]}},
    "settings": {"max_edge": 2.0, "quadrature": 8}})";
  const std::string out = (dir / "scene.vtu").string();
  const CliRun r = run("solve " + (dir / "scene.json").string() + " -o " + out + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto s = nlohmann::json::parse(r.out);
  EXPECT_EQ(s["patches"], 2);  // settings.max_edge = 2 keeps each unit square whole
  EXPECT_EQ(s["quadrature"], 8);
  const VtuGrid g = photometria::read_vtu(out);
  const auto& B = array(g.cell_arrays, "radiosity").values;
  const auto& H = array(g.cell_arrays, "irradiance").values;
  // Top square (cell 1): H = F(top -> bottom) · 1 with F ≈ Howell C-11 = 0.19982, B = ρ H.
  EXPECT_NEAR(H[3], 0.19982489569838738, 1e-6);
  EXPECT_NEAR(B[3], 0.25 * H[3], 1e-12);
  EXPECT_NEAR(B[4], 0.5 * H[4], 1e-12);
  EXPECT_NEAR(B[5], 0.75 * H[5], 1e-12);
  // A command-line option wins over the scene file's settings.
  const CliRun r2 = run("solve " + (dir / "scene.json").string() + " -o " + out + " --json --max-edge 0.5");
  ASSERT_EQ(r2.exit_code, 0) << r2.err;
  EXPECT_EQ(nlohmann::json::parse(r2.out)["patches"], 8);
}

TEST(Cli, NothingToSolveIsABadInput) {
  const fs::path dir = scratch();
  std::ofstream(dir / "dark.off") << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  const CliRun r = run("solve " + (dir / "dark.off").string() + " -o " + (dir / "dark.vtu").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("nothing to solve"), std::string::npos) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  // No output and no temporary beside it.
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_NE(e.path().filename().string().rfind("dark.vtu", 0), 0u) << e.path();
  const CliRun lit =
      run("solve " + (dir / "dark.off").string() + " -o " + (dir / "dark.vtu").string() + " --emission 2");
  EXPECT_EQ(lit.exit_code, 0) << lit.err;
}

// --accuracy: the per-pair rule reaches the exact 6 × 6 solution of the closed cube with one
// patch per wall and only the floor emitting (refs cube_floor_emitting_rho0.5).
TEST(Cli, AccuracyOptionReachesTheExactCubeSolution) {
  const fs::path dir = scratch();
  std::ofstream(dir / "cube.mtl") << "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl floor\nKd 0.5 0.5 0.5\nKe 1 1 1\n";
  std::ofstream(dir / "cube.obj")
      << "mtllib cube.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
      << "usemtl floor\nf 1 2 3 4\nusemtl wall\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n";
  const std::string out = (dir / "cube.vtu").string();
  const CliRun r = run("solve " + (dir / "cube.obj").string() + " -o " + out +
                       " --max-edge 2 --accuracy 1e-8 --tolerance 1e-13 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto s = nlohmann::json::parse(r.out);
  EXPECT_EQ(s["patches"], 6);
  // Every pair is a pair of aligned rectangles: all 30 take the closed form.
  EXPECT_EQ(s["pair_rules"]["exact_rectangles"].get<int>(), 30);
  EXPECT_EQ(s["pair_rules"]["adaptive"].get<int>() + s["pair_rules"]["gauss"].get<int>(), 0);
  const VtuGrid g = photometria::read_vtu(out);
  const auto& B = array(g.cell_arrays, "radiosity").values;
  const std::vector<double> want = {1.0909090981076954743, 0.18174582610778848093, 0.18183626894612901119};
  // Exact factors: only the solver tolerance (1e-13) and rounding are left.
  EXPECT_NEAR(B[0], want[0], 1e-12 * want[0]);
  EXPECT_NEAR(B[3], want[1], 1e-12 * want[1]);
  for (int wall = 2; wall < 6; ++wall) EXPECT_NEAR(B[3 * wall], want[2], 1e-12 * want[2]);
}

// Analytic lights from a scene file: a normalized distant light gives exactly its intensity as
// irradiance on a surface facing it (UsdLux note, kernels/distant.h), so a lone floor of ρ = 0.5
// has B = 500.
TEST(Cli, SceneFileLightsGiveDirectIrradiance) {
  const fs::path dir = scratch();
  std::ofstream(dir / "floor.off") << "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
  std::ofstream(dir / "sun.json") << R"({"meshes": [{"file": "floor.off", "reflectance": [0.5, 0.5, 0.5]}],
    "lights": [{"type": "distant", "direction": [0, 0, 1], "angle": 0.53, "intensity": 1000, "normalize": true}]})";
  const std::string out = (dir / "sun.vtu").string();
  const CliRun r = run("solve " + (dir / "sun.json").string() + " -o " + out + " --max-edge 0.5 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto s = nlohmann::json::parse(r.out);
  EXPECT_EQ(s["lights"], 1);
  EXPECT_NEAR(s["energy_w"]["direct_in"][0].get<double>(), 1000.0, 1e-9);
  EXPECT_LE(s["energy_w"]["relative_imbalance"].get<double>(), 1e-12);
  const VtuGrid g = photometria::read_vtu(out);
  for (double b : array(g.cell_arrays, "radiosity").values) EXPECT_NEAR(b, 500.0, 1e-9);
  for (double b : array(g.point_arrays, "radiosity").values) EXPECT_NEAR(b, 500.0, 1e-9);
}

// Grey materials under a coloured light: each channel is solved (one grey channel copied to
// the others would give every channel the red one's 500).
TEST(Cli, ColouredLightOnGreyMaterialsSolvesEveryChannel) {
  const fs::path dir = scratch();
  std::ofstream(dir / "floor.off") << "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
  std::ofstream(dir / "red_sun.json") << R"({"meshes": [{"file": "floor.off", "reflectance": [0.5, 0.5, 0.5]}],
    "lights": [{"type": "distant", "direction": [0, 0, 1], "angle": 0.53, "intensity": [1000, 400, 0], "normalize": true}]})";
  const std::string out = (dir / "red_sun.vtu").string();
  const CliRun r = run("solve " + (dir / "red_sun.json").string() + " -o " + out + " --max-edge 0.5 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto s = nlohmann::json::parse(r.out);
  EXPECT_EQ(s["solver"]["channels"], 3);
  const VtuGrid g = photometria::read_vtu(out);
  const double want[3] = {500.0, 200.0, 0.0};
  for (const char* where : {"cells", "points"}) {
    const auto& b = array(std::string(where) == "cells" ? g.cell_arrays : g.point_arrays, "radiosity").values;
    ASSERT_EQ(b.size() % 3, 0u);
    for (size_t k = 0; k < b.size(); ++k) EXPECT_NEAR(b[k], want[k % 3], 1e-9) << where << " value " << k;
  }
}

// `validate --quick --report DIR`: the table as CSV and, through gnuplot, the error-against-time
// plot (docs/validation.md). Without gnuplot the plot cannot be made: exit 2 naming gnuplot, the
// CSV still written.
TEST(Cli, ValidateQuickReportWritesTheTableAndThePlot) {
  const fs::path dir = scratch() / "validation_report";
  fs::remove_all(dir);
  const CliRun r = run("validate --quick --report " + dir.string());
  const bool gnuplot = std::system("which gnuplot >/dev/null 2>&1") == 0;
  if (gnuplot) {
    EXPECT_EQ(r.exit_code, 0) << r.err;
  } else {
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("gnuplot"), std::string::npos) << r.err;
  }
  std::ifstream in(dir / "validation.csv");
  ASSERT_TRUE(in) << "no " << (dir / "validation.csv");
  std::string header, line;
  ASSERT_TRUE(std::getline(in, header));
  EXPECT_EQ(header, "scene,setting,patches,quadrature,cases,max_rel_error,rms_rel_error,seconds");
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    ++rows;
    EXPECT_GE(std::count(line.begin(), line.end(), ','), 7) << line;
  }
  EXPECT_GE(rows, 5);
  // The summary on stdout has one line per row plus its header.
  EXPECT_EQ(count_lines(r.out), rows + 1) << r.out;
  if (gnuplot) {
    const fs::path png = dir / "error_vs_time.png";
    ASSERT_TRUE(fs::exists(png));
    EXPECT_GT(fs::file_size(png), 1000u);
    std::ifstream p(png, std::ios::binary);
    char magic[8] = {};
    p.read(magic, 8);
    EXPECT_EQ(std::string(magic, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  }
}

// Ray visibility: adaptive by default (the summary names the sampling and the estimated error of
// a row sum from the rays); a fixed count from --rays or from the scene file's settings.
TEST(Cli, RaySamplingIsAdaptiveByDefaultAndReportsItsError) {
  const fs::path dir = scratch();
  const std::string out = (dir / "rays.vtu").string();
  const std::string base = "solve " + mesh("cornell_box.obj") + " -o " + out + " --json --max-edge 0.5";
  const CliRun adaptive = run(base + " --visibility rays");
  ASSERT_EQ(adaptive.exit_code, 0) << adaptive.err;
  const auto a = nlohmann::json::parse(adaptive.out)["visibility"];
  EXPECT_EQ(a["ray_sampling"].get<std::string>().rfind("adaptive, 8² to 32² rays", 0), 0u) << a;
  EXPECT_GT(a["rays_cast"].get<long long>(), 0);
  // The blocks shadow parts of the floor and walls: a small but non-zero error estimate.
  EXPECT_GT(a["row_ray_error_max"].get<double>(), 0.0);
  EXPECT_LT(a["row_ray_error_max"].get<double>(), 0.05);
  const CliRun fixed = run(base + " --visibility rays --rays 64");
  ASSERT_EQ(fixed.exit_code, 0) << fixed.err;
  EXPECT_EQ(nlohmann::json::parse(fixed.out)["visibility"]["ray_sampling"], "64 rays per point and patch");
  std::ofstream(dir / "rays.json") << R"({"meshes": [{"file": ")" << mesh("cornell_box.obj") << R"("}],
    "settings": {"max_edge": 0.5, "visibility": "rays", "rays": 16}})";
  const CliRun from_file = run("solve " + (dir / "rays.json").string() + " -o " + out + " --json");
  ASSERT_EQ(from_file.exit_code, 0) << from_file.err;
  EXPECT_EQ(nlohmann::json::parse(from_file.out)["visibility"]["ray_sampling"], "16 rays per point and patch");
  // Exact visibility: no ray sampling to report.
  const CliRun exact = run(base + " --visibility exact");
  ASSERT_EQ(exact.exit_code, 0) << exact.err;
  EXPECT_EQ(nlohmann::json::parse(exact.out)["visibility"]["ray_sampling"], "");
}

// --crease-angle: the Cornell box's left wall is not planar and is split into two triangles on
// load; at the default 30° the two share their diagonal's points, at 0 they do not.
TEST(Cli, CreaseAngleJoinsTheSplitWallsPoints) {
  const std::string out = (scratch() / "crease.vtu").string();
  const std::string base = "solve " + mesh("cornell_box.obj") + " -o " + out + " --json --max-edge 0.5";
  const CliRun smooth = run(base), sharp = run(base + " --crease-angle 0");
  ASSERT_EQ(smooth.exit_code, 0) << smooth.err;
  ASSERT_EQ(sharp.exit_code, 0) << sharp.err;
  const auto s = nlohmann::json::parse(smooth.out), h = nlohmann::json::parse(sharp.out);
  EXPECT_EQ(s["crease_angle_degrees"], 30.0);
  EXPECT_EQ(h["crease_angle_degrees"], 0.0);
  EXPECT_LT(s["output_points"].get<int>(), h["output_points"].get<int>());
  EXPECT_EQ(photometria::read_vtu(out).points.size(), h["output_points"].get<size_t>());
}

// `--method hierarchical`: the leaves are the cells (cut at T-junctions), the summary says what the hierarchy did,
// the arrays are those of the dense method; a method that does not exist is refused.
TEST(Cli, HierarchicalMethodWritesTheLeavesAndReportsTheHierarchy) {
  const std::string out = (scratch() / "cornell_hierarchical.vtu").string();
  const CliRun r = run("solve " + mesh("cornell_box.obj") + " -o " + out + " --method hierarchical --error 0.3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto s = nlohmann::json::parse(r.out);
  EXPECT_EQ(s["method"], "hierarchical");
  const auto& h = s["hierarchical"];
  EXPECT_EQ(h["error"].get<double>(), 0.3);
  EXPECT_EQ(h["roots"].get<int>(), s["faces"].get<int>());
  EXPECT_GT(h["leaves"].get<int>(), h["roots"].get<int>());
  EXPECT_GT(h["links"].get<long long>(), 0);
  EXPECT_FALSE(h["stopped_by_memory"].get<bool>());
  EXPECT_TRUE(s["solver"]["converged"].get<bool>());
  EXPECT_LT(s["energy_w"]["relative_imbalance"].get<double>(), 0.1);
  const VtuGrid g = photometria::read_vtu(out);
  // Leaves with a finer neighbour's corners inside an edge are written as triangles (output_cells.h).
  EXPECT_GT(g.cells.size(), h["leaves"].get<size_t>());
  for (const std::string name : {"radiosity", "irradiance"})
    for (double v : array(g.point_arrays, name).values) ASSERT_TRUE(std::isfinite(v) && v >= 0) << name;

  EXPECT_EQ(h["clusters"].get<int>(), 0);  // few faces: every facing pair linked (--cluster-above 512)
  EXPECT_EQ(h["cluster_links"].get<long long>(), 0);
  const CliRun clustered = run("solve " + mesh("cornell_box.obj") + " -o " + out +
                               " --method hierarchical --error 0.3 --cluster-above 0 --json");
  ASSERT_EQ(clustered.exit_code, 0) << clustered.err;
  const auto c = nlohmann::json::parse(clustered.out)["hierarchical"];
  EXPECT_EQ(c["clusters"].get<int>(), c["roots"].get<int>() - 1);
  EXPECT_TRUE(c.contains("cluster_links"));
  const CliRun no_clusters =
      run("solve " + mesh("cornell_box.obj") + " -o " + out + " --method hierarchical --cluster-above -2");
  EXPECT_EQ(no_clusters.exit_code, 1);
  EXPECT_NE(no_clusters.err.find("--cluster-above"), std::string::npos) << no_clusters.err;

  const CliRun bad = run("solve " + mesh("cornell_box.obj") + " -o " + out + " --method sparse");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("--method: 'sparse' is not dense, hierarchical or auto"), std::string::npos) << bad.err;
  const CliRun dense = run("solve " + mesh("cornell_box.obj") + " -o " + out + " --json");
  ASSERT_EQ(dense.exit_code, 0) << dense.err;
  EXPECT_EQ(nlohmann::json::parse(dense.out)["method"], "dense");
  EXPECT_EQ(nlohmann::json::parse(dense.out)["method_reason"], "requested (--method dense)");
}

// `--method auto`: dense while its memory estimate fits the limit, else the hierarchy, and the
// summary says which and why.
TEST(Cli, AutoMethodIsDenseWhenItFitsAndHierarchicalWhenNot) {
  const std::string out = (scratch() / "cornell_auto.vtu").string();
  CliRun r = run("solve " + mesh("cornell_box.obj") + " -o " + out + " --method auto --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto s = nlohmann::json::parse(r.out);
  EXPECT_EQ(s["method"], "dense");
  std::string reason = s["method_reason"].get<std::string>();
  EXPECT_EQ(reason.rfind("auto: the dense method needs ", 0), 0u) << reason;
  EXPECT_NE(reason.find(", within "), std::string::npos) << reason;
  // Patches of 2 cm: the dense matrix would need gigabytes, over a 256 MiB limit.
  r = run("solve " + mesh("cornell_box.obj") + " -o " + out +
          " --method auto --max-edge 0.02 --max-memory 256M --error 0.3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  s = nlohmann::json::parse(r.out);
  EXPECT_EQ(s["method"], "hierarchical");
  reason = s["method_reason"].get<std::string>();
  EXPECT_NE(reason.find(", over --max-memory is 256 MiB"), std::string::npos) << reason;
  EXPECT_EQ(s["hierarchical"]["roots"].get<int>(), s["faces"].get<int>());
  EXPECT_GE(photometria::read_vtu(out).cells.size(), s["hierarchical"]["leaves"].get<size_t>());
}

// OBJ vn through the command line: the furnace cube whose corners each give all three faces one
// vn (the diagonal, into the cube). Whole faces (--max-edge 2): 8 output points, whatever the
// crease angle; without the vn its 90° edges keep 24. Cut into 4 × 4 patches per face: the vn
// interpolated along the edges agree from both faces, so every patch vertex is one point (6 × 9
// inside the faces, 12 × 3 on the edges, 8 corners; 150 without vn), and every point is exact
// (B = E / (1 − ρ) = 2) with its tilted normal.
TEST(Cli, VertexNormalsJoinTheCubesCorners) {
  const fs::path dir = scratch();
  std::ofstream(dir / "vn_cube.mtl") << "newmtl furnace\nKd 0.5\nKe 1\n";
  const std::string vertices = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
  const std::string normals =
      "vn 1 1 1\nvn -1 1 1\nvn -1 -1 1\nvn 1 -1 1\nvn 1 1 -1\nvn -1 1 -1\nvn -1 -1 -1\nvn 1 -1 -1\n";
  const int faces[6][4] = {{1, 2, 3, 4}, {5, 8, 7, 6}, {1, 5, 6, 2}, {2, 6, 7, 3}, {3, 7, 8, 4}, {4, 8, 5, 1}};
  std::string with_vn, without_vn;
  for (const auto& f : faces) {
    with_vn += "f";
    without_vn += "f";
    for (int v : f) {
      with_vn.append(" ").append(std::to_string(v)).append("//").append(std::to_string(v));
      without_vn.append(" ").append(std::to_string(v));
    }
    with_vn += "\n";
    without_vn += "\n";
  }
  const std::string head = "mtllib vn_cube.mtl\n" + vertices + normals + "usemtl furnace\n";
  std::ofstream(dir / "vn_cube.obj") << head + with_vn;
  std::ofstream(dir / "no_vn_cube.obj") << head + without_vn;
  const std::string out = (dir / "vn_cube.vtu").string();
  auto solve = [&](const std::string& file, const std::string& options) {
    const CliRun r = run("solve " + (dir / file).string() + " -o " + out + " --json --tolerance 1e-12 " + options);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0 ? nlohmann::json::parse(r.out)["output_points"].get<int>() : -1;
  };
  for (const std::string options : {"--max-edge 2", "--max-edge 2 --crease-angle 0", "--max-edge 0.25"}) {
    SCOPED_TRACE(options);
    const int points = solve("vn_cube.obj", options);
    EXPECT_EQ(points, options == "--max-edge 0.25" ? 6 * 9 + 12 * 3 + 8 : 8);
    const VtuGrid g = photometria::read_vtu(out);
    EXPECT_EQ(g.points.size(), size_t(points));
    for (double b : array(g.point_arrays, "radiosity").values) EXPECT_NEAR(b, 2.0, 1e-6);
  }
  EXPECT_EQ(solve("no_vn_cube.obj", "--max-edge 2"), 24);
  EXPECT_EQ(solve("no_vn_cube.obj", "--max-edge 0.25"), 150);
}
