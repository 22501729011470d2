// Bad input through the command line: every fault gets one clear line on stderr, the
// documented exit code, and no output file (nor temporary file) is left behind; the cases that
// can safely go on give a counted warning in the --json summary and a finite result.
// (Missing file, malformed OBJ number, ρ >= 1, unwritable output and nothing to solve are in
// test_cli.cpp.)
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "cli_run.h"
#include "io/vtu.h"
#include "pipeline/memory.h"
#include "scene/scene.h"
#include "scratch_dir.h"

namespace fs = std::filesystem;

namespace {

using cli_test::CliRun;

// A fresh folder per test, removed afterwards.
class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = test_scratch::fresh_dir("photometria_bad_" + std::string(info->name()) + "_");
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }

  CliRun run(const std::string& args) const {
    return cli_test::run_cli(args, (dir_.parent_path() / (dir_.filename().string() + ".stderr")).string());
  }

  // Solves `scene` into out.vtu and expects the failure: exit code, one line naming every part,
  // and nothing written into the folder (neither out.vtu nor a temporary file).
  void expect_failure(const std::string& scene, int code, const std::vector<std::string>& parts,
                      const std::string& options = "") const {
    const std::string out = path("out.vtu");
    const auto before = files();
    const CliRun r = run("solve " + scene + " -o " + out + " " + options);
    EXPECT_EQ(r.exit_code, code) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line expected: " << r.err;
    EXPECT_EQ(r.err.rfind("photometria: ", 0), 0u) << r.err;
    for (const std::string& p : parts) EXPECT_NE(r.err.find(p), std::string::npos) << "'" << p << "' not in: " << r.err;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_EQ(files(), before) << "a file was left behind";
  }

  // Solves and returns the --json summary, expecting success and a finite result.
  nlohmann::json solve_ok(const std::string& scene, const std::string& options, std::string* err = nullptr) const {
    const std::string out = path("out.vtu");
    const CliRun r = run("solve " + scene + " -o " + out + " --json " + options);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    if (err) *err = r.err;
    if (r.exit_code != 0) return {};
    const photometria::VtuGrid g = photometria::read_vtu(out);
    for (const auto* arrays : {&g.point_arrays, &g.cell_arrays})
      for (const auto& a : *arrays)
        for (double v : a.values) EXPECT_TRUE(std::isfinite(v)) << a.name;
    return nlohmann::json::parse(r.out);
  }

  // Cell radiosity (channel 0) of the last solve.
  std::vector<double> cell_radiosity() const {
    for (const auto& a : photometria::read_vtu(path("out.vtu")).cell_arrays)
      if (a.name == "radiosity") {
        std::vector<double> b;
        for (size_t i = 0; i < a.values.size(); i += 3) b.push_back(a.values[i]);
        return b;
      }
    return {};
  }

  std::set<std::string> files() const {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.insert(e.path().filename().string());
    return names;
  }

  fs::path dir_;
};

// The unit cube, faces wound counter-clockwise seen from inside (fronts inward), one material
// with ρ = 0.5 and E = 1: the furnace, B = E / (1 − ρ) = 2 on every patch.
const char* kCubeVertices = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
const char* kCubeFaces[6] = {"f 1 2 3 4\n", "f 5 8 7 6\n", "f 1 5 6 2\n", "f 2 6 7 3\n", "f 3 7 8 4\n", "f 4 8 5 1\n"};
const char* kFurnaceMtl = "newmtl furnace\nKd 0.5\nKe 1\n";

std::string cube(const std::string& extra_faces = "", int reversed_face = -1, bool all_reversed = false) {
  std::string s = "mtllib furnace.mtl\n" + std::string(kCubeVertices) + "usemtl furnace\n";
  for (int f = 0; f < 6; ++f) {
    std::string face = kCubeFaces[f];
    if (f == reversed_face || all_reversed) {
      std::istringstream in(face.substr(2));
      std::vector<std::string> v{std::istream_iterator<std::string>(in), {}};
      face = "f";
      for (auto it = v.rbegin(); it != v.rend(); ++it) face += " " + *it;
      face += "\n";
    }
    s += face;
  }
  return s + extra_faces;
}

}  // namespace

// ----- errors -----------------------------------------------------------------------------------

TEST_F(BadInput, UnreadableFileIsAnIoError) {
  fs::create_directories(path("room.obj"));  // a folder where a file should be (root reads any file)
  expect_failure(path("room.obj"), 2, {"cannot open", "room.obj"});
}

TEST_F(BadInput, UnknownExtension) {
  expect_failure(write("room.dae", "<COLLADA/>"), 1, {"room.dae", "unknown mesh format", "'.dae'"});
}

TEST_F(BadInput, MalformedMtlNumberNamesFileLineAndValue) {
  write("m.mtl", "newmtl white\nKd 0.5 x 0.5\n");
  expect_failure(write("r.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl white\nf 1 2 3\n"), 1,
                 {"m.mtl:2", "'x'"});
}

TEST_F(BadInput, MalformedJsonNamesTheLine) {
  expect_failure(write("scene.json", "{\"meshes\": [\n  {\"file\": \"a.obj\"},,\n]}\n"), 1, {"scene.json:2"});
}

TEST_F(BadInput, JsonValueOfTheWrongType) {
  write("furnace.mtl", kFurnaceMtl);
  write("cube.obj", cube());
  expect_failure(write("scene.json", R"({"meshes": [{"file": "cube.obj"}],
                                         "materials": {"furnace": {"reflectance": "half"}}})"),
                 1, {"scene.json", "materials.furnace.reflectance", "\"half\""});
}

TEST_F(BadInput, FaceIndexOutOfRange) {
  expect_failure(write("r.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), 1, {"r.obj:4", "9", "out of range"},
                 "--emission 1");
}

// A vn becomes a point's normal, so one without a direction is refused where it stands.
TEST_F(BadInput, VertexNormalWithoutDirection) {
  expect_failure(write("r.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 0\nf 1//1 2//2 3//1\n"), 1,
                 {"r.obj:5", "vn 0 0 0 has no direction"}, "--emission 1");
}

TEST_F(BadInput, FaceWithTwoVertices) {
  expect_failure(write("r.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n"), 1, {"r.obj:4", "f with 2 vertices"},
                 "--emission 1");
}

TEST_F(BadInput, NanCoordinate) {
  expect_failure(write("r.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"), 1,
                 {"r.obj:2", "'nan'", "not a finite number"}, "--emission 1");
}

TEST_F(BadInput, InfiniteCoordinate) {
  expect_failure(write("r.obj", "v 0 0 0\nv 1 0 0\nv 0 1e999 0\nf 1 2 3\n"), 1,
                 {"r.obj:3", "'1e999'", "not a finite number"}, "--emission 1");
  expect_failure(write("r.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 inf 0\n3 0 1 2\n"), 1, {"r.off", "inf"}, "--emission 1");
}

TEST_F(BadInput, NanInMaterial) {
  write("m.mtl", "newmtl lamp\nKd 0.5\nKe 1 NaN 1\n");
  expect_failure(write("r.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n"), 1,
                 {"m.mtl:3", "'NaN'", "not a finite number"});
}

TEST_F(BadInput, InfiniteJsonNumber) {
  write("furnace.mtl", kFurnaceMtl);
  write("cube.obj", cube());
  // Too large for a double: refused while parsing, naming the line and the number.
  expect_failure(write("scene.json", "{\"meshes\": [{\"file\": \"cube.obj\"}],\n \"settings\": {\"max_edge\": 1e999}}"),
                 1, {"scene.json:2", "'1e999'", "not a finite number"});
}

TEST_F(BadInput, NanOnTheCommandLine) {
  write("furnace.mtl", kFurnaceMtl);
  const std::string obj = write("cube.obj", cube());
  expect_failure(obj, 1, {"--max-edge"}, "--max-edge nan");
  expect_failure(write("t.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), 1, {"--emission", "'nan'"},
                 "--emission nan");
}

TEST_F(BadInput, NegativeReflectance) {
  write("m.mtl", "newmtl dark\nKd -0.1 0.5 0.5\nKe 1\n");
  expect_failure(write("r.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl dark\nf 1 2 3\n"), 1,
                 {"m.mtl:1", "'dark'", "reflectance -0.1", "[0, 1)"});
}

TEST_F(BadInput, NegativeEmission) {
  write("m.mtl", "newmtl sink\nKd 0.5\nKe -1\n");
  expect_failure(write("r.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl sink\nf 1 2 3\n"), 1,
                 {"m.mtl:1", "'sink'", "emission -1", ">= 0"});
  expect_failure(write("t.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), 1, {"emission -2"}, "--emission -2");
}

TEST_F(BadInput, OutputPathIsAFolder) {
  write("furnace.mtl", kFurnaceMtl);
  const std::string obj = write("cube.obj", cube());
  fs::create_directories(path("out.vtu"));
  const CliRun r = run("solve " + obj + " -o " + path("out.vtu"));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("it is a folder"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_directory(path("out.vtu")));
  EXPECT_EQ(files(), (std::set<std::string>{"cube.obj", "furnace.mtl", "out.vtu"}));
}

TEST_F(BadInput, MemoryEstimateAboveTheLimitIsRefused) {
  write("furnace.mtl", kFurnaceMtl);
  const std::string obj = write("cube.obj", cube());
  // --max-edge 0.05: 20 × 20 patches per wall, N = 2400, dense form factors alone 2400² × 8 bytes = 44 MiB.
  expect_failure(obj, 1,
                 {"needs ", " MiB for 2,400 patches (dense double form factors)", "--max-memory is 16 MiB",
                  "raise --max-edge", "use --method hierarchical"},
                 "--max-edge 0.05 --max-memory 16M");
  // The figure: at least the matrix (44 MiB), plus well under 4 kB per patch for the rest.
  const CliRun r = run("solve " + obj + " -o " + path("out.vtu") + " --max-edge 0.05 --max-memory 16M");
  const size_t at = r.err.find("needs ");
  ASSERT_NE(at, std::string::npos) << r.err;
  const double mib = std::stod(r.err.substr(at + 6));
  EXPECT_GE(mib, 2400.0 * 2400 * 8 / 1048576);
  EXPECT_LT(mib, (2400.0 * 2400 * 8 + 2400 * 4096.0) / 1048576);
  expect_failure(obj, 1, {"--max-memory", "'lots'"}, "--max-memory lots");
}

// Between the float and the double estimate, `--matrix-precision auto` (the default) stores the
// factors in float and says why; `double` asked for is refused.
TEST_F(BadInput, FloatStorageWhenOnlyFloatFits) {
  write("furnace.mtl", kFurnaceMtl);
  const std::string obj = write("cube.obj", cube());
  // N = 2400: 44 MiB dense double, 22 MiB dense float, plus the per-patch arrays (under 10 MiB).
  const nlohmann::json s = solve_ok(obj, "--max-edge 0.05 --max-memory 40M");
  EXPECT_EQ(s["matrix"]["storage"], "dense float");
  const std::string reason = s["matrix"]["reason"];
  EXPECT_NE(reason.find("float entries, because double"), std::string::npos) << reason;
  EXPECT_NE(reason.find("would exceed --max-memory (40 MiB)"), std::string::npos) << reason;
  EXPECT_LE(s["matrix"]["estimated_bytes"].get<double>(), 40.0 * 1048576);
  EXPECT_DOUBLE_EQ(s["matrix"]["bytes"].get<double>(), 2400.0 * 2400 * 4);
  fs::remove(path("out.vtu"));
  expect_failure(obj, 1, {"(dense double form factors)", "--max-memory is 40 MiB"},
                 "--max-edge 0.05 --max-memory 40M --matrix-precision double");
  // With room to spare, auto is double.
  EXPECT_EQ(solve_ok(obj, "--max-edge 0.05 --max-memory 1G")["matrix"]["storage"], "dense double");
}

TEST(StorageChoice, AutoPrecisionIsDoubleUnlessOnlyFloatFits) {
  using namespace photometria;
  const double n = 1000, dense_double = 8e6, dense_float = 4e6, rest = 1e5;
  StorageChoice c = choose_storage(MatrixLayout::Auto, MatrixPrecision::Auto, n, n * (n - 1), rest, 1e9);
  EXPECT_EQ(c.storage, "dense double");
  EXPECT_TRUE(c.fits);
  c = choose_storage(MatrixLayout::Auto, MatrixPrecision::Auto, n, n * (n - 1), rest, dense_double);
  EXPECT_EQ(c.storage, "dense float");
  EXPECT_DOUBLE_EQ(c.estimated_bytes, dense_float + rest);
  EXPECT_TRUE(c.fits);
  // Neither fits: double is kept (and refused by the caller), so the message names the default.
  c = choose_storage(MatrixLayout::Auto, MatrixPrecision::Auto, n, n * (n - 1), rest, dense_float);
  EXPECT_EQ(c.storage, "dense double");
  EXPECT_FALSE(c.fits);
  // Requested precisions are kept whatever the limit.
  c = choose_storage(MatrixLayout::Dense, MatrixPrecision::Double, n, 0, rest, 1e6);
  EXPECT_EQ(c.storage, "dense double");
  EXPECT_FALSE(c.fits);
  EXPECT_EQ(c.reason, "requested (--matrix dense)");
  // Sparse when few pairs face each other, float on top when the limit needs it.
  c = choose_storage(MatrixLayout::Auto, MatrixPrecision::Auto, n, 0.1 * n * n, rest, 0.1 * n * n * 10);
  EXPECT_EQ(c.storage, "sparse float");
}

// ----- the memory estimate in the summary -------------------------------------------------------

TEST_F(BadInput, MemoryEstimateIsInTheSummary) {
  write("furnace.mtl", kFurnaceMtl);
  const nlohmann::json s = solve_ok(write("cube.obj", cube()), "--max-edge 0.25 --max-memory 1G");
  const auto& m = s["memory_estimate"];
  const double n = 96;  // 4 × 4 patches per wall
  ASSERT_EQ(s["patches"], 96);
  // Patches on different walls of a cube face each other, patches of one wall never:
  // N (N − 1) − 6 · 16 · 15 pairs, counted exactly below 16384 pairs.
  EXPECT_EQ(m["nonzero_pairs"], 96 * 95 - 6 * 16 * 15);
  const double rest = m["per_patch_bytes"].get<double>() * n;
  EXPECT_GT(m["per_patch_bytes"].get<double>(), 0);
  EXPECT_DOUBLE_EQ(m["dense_bytes"].get<double>(), n * n * 8 + rest);
  EXPECT_DOUBLE_EQ(m["sparse_bytes"].get<double>(), (96 * 95 - 6 * 16 * 15) * 12.0 + (n + 1) * 8 + rest);
  EXPECT_DOUBLE_EQ(m["limit_bytes"].get<double>(), 1024.0 * 1024 * 1024);
  EXPECT_EQ(m["limit_source"], "--max-memory");
}

TEST(MemorySize, ParsingAndFormatting) {
  using photometria::parse_memory_size;
  double b = 0;
  EXPECT_TRUE(parse_memory_size("512M", b));
  EXPECT_EQ(b, 512.0 * 1024 * 1024);
  EXPECT_TRUE(parse_memory_size("1.5GiB", b));
  EXPECT_EQ(b, 1.5 * 1024 * 1024 * 1024);
  EXPECT_TRUE(parse_memory_size("64k", b));
  EXPECT_EQ(b, 65536);
  EXPECT_TRUE(parse_memory_size("2TB", b));
  EXPECT_EQ(b, 2.0 * 1024 * 1024 * 1024 * 1024);
  EXPECT_TRUE(parse_memory_size("1000", b));
  EXPECT_EQ(b, 1000);
  for (const char* bad : {"lots", "", "-1G", "0", "nanG", "infM", "1X", "1GG", "1 G"})
    EXPECT_FALSE(parse_memory_size(bad, b)) << bad;
  EXPECT_EQ(photometria::format_bytes(1.6 * 1024 * 1024 * 1024), "1.6 GiB");
  EXPECT_EQ(photometria::format_bytes(1024.0 * 1024 * 1024), "1 GiB");
  EXPECT_EQ(photometria::format_bytes(44.0 * 1024 * 1024 + 1), "44 MiB");
  EXPECT_EQ(photometria::format_bytes(100), "100 bytes");
  EXPECT_EQ(photometria::format_count(14000), "14,000");
  EXPECT_EQ(photometria::format_count(1234567), "1,234,567");
  EXPECT_EQ(photometria::format_count(999), "999");
}

// ----- counted warnings -------------------------------------------------------------------------

TEST_F(BadInput, ZeroAreaFacesAreDroppedWithAWarning) {
  write("furnace.mtl", kFurnaceMtl);
  // f 1 2 2 repeats a vertex, f 1 2 <(2,0,0)> is collinear.
  const std::string extra = "v 2 0 0\nf 1 2 2\nf 1 2 9\n";
  std::string err;
  const nlohmann::json s = solve_ok(write("cube.obj", cube(extra)), "--max-edge 0.5", &err);
  EXPECT_EQ(s["load"]["dropped_degenerate"], 2);
  EXPECT_EQ(s["faces"], 6);
  EXPECT_NE(err.find("warning: " + path("cube.obj") + ": 2 zero-area"), std::string::npos) << err;
}

TEST_F(BadInput, DuplicateFacesAreDroppedAndCounted) {
  write("furnace.mtl", kFurnaceMtl);
  // The floor again, started at another corner; and the ceiling as its back-to-back twin
  // (reverse winding: a two-sided sheet, kept).
  const nlohmann::json s =
      solve_ok(write("cube.obj", cube("f 3 4 1 2\nf 6 7 8 5\n")), "--max-edge 0.5 --tolerance 1e-12");
  EXPECT_EQ(s["load"]["duplicate_faces"], 1);
  EXPECT_EQ(s["warnings"].size(), 1u) << s["warnings"];
  EXPECT_EQ(s["load"]["input_faces"], 8);
  EXPECT_EQ(s["faces"], 7);
}

TEST_F(BadInput, DuplicateFaceLeavesTheFurnaceExact) {
  write("furnace.mtl", kFurnaceMtl);
  const nlohmann::json s = solve_ok(write("cube.obj", cube("f 2 3 4 1\n")), "--max-edge 0.5 --tolerance 1e-12");
  EXPECT_EQ(s["load"]["duplicate_faces"], 1);
  for (double b : cell_radiosity()) EXPECT_NEAR(b, 2.0, 1e-9);  // E / (1 − ρ): nothing counted twice
}

TEST_F(BadInput, NonPlanarQuadIsSplitWithAWarning) {
  const nlohmann::json s =
      solve_ok(write("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0.3\nv 0 1 0\nf 1 2 3 4\n"), "--emission 1");
  EXPECT_EQ(s["load"]["split_nonplanar"], 1);
  EXPECT_EQ(s["faces"], 2);
}

TEST_F(BadInput, MissingMtlGivesDefaultsAndAWarning) {
  // furnace.mtl is not there: usemtl furnace gets --reflectance 0.5 / --emission 1, the furnace again.
  std::string err;
  const nlohmann::json s = solve_ok(write("cube.obj", cube()), "--max-edge 0.5 --emission 1 --tolerance 1e-12", &err);
  EXPECT_EQ(s["load"]["missing_material_files"], 1);
  EXPECT_NE(err.find("1 material file(s) (mtllib) missing"), std::string::npos) << err;
  for (double b : cell_radiosity()) EXPECT_NEAR(b, 2.0, 1e-9);
}

TEST_F(BadInput, FaceFlippedInAClosedRoomIsFixedAndCounted) {
  write("furnace.mtl", kFurnaceMtl);
  const std::string obj = write("cube.obj", cube("", /*reversed_face=*/3));
  std::string err;
  const nlohmann::json s = solve_ok(obj, "--max-edge 0.5 --tolerance 1e-12", &err);
  EXPECT_EQ(s["load"]["flipped_faces"], 1);
  EXPECT_EQ(s["load"]["enclosure_faces_outward"], false);
  EXPECT_NE(err.find("1 face(s) wound against the rest of their closed surface flipped"), std::string::npos) << err;
  for (double b : cell_radiosity()) EXPECT_NEAR(b, 2.0, 1e-9);  // the furnace, as if never flipped

  // Left as it is, the flipped wall faces out of the room: it receives nothing (B = E = 1 there).
  const nlohmann::json kept = solve_ok(obj, "--max-edge 0.5 --tolerance 1e-12 --keep-orientation");
  EXPECT_EQ(kept["load"]["flipped_faces"], 0);
  const std::vector<double> b = cell_radiosity();
  EXPECT_EQ(std::count_if(b.begin(), b.end(), [](double x) { return std::abs(x - 1.0) < 1e-12; }), 4);
}

TEST_F(BadInput, InsideOutRoomIsReportedAndFlipNormalsFixesIt) {
  write("furnace.mtl", kFurnaceMtl);
  const std::string obj = write("cube.obj", cube("", -1, /*all_reversed=*/true));
  std::string err;
  const nlohmann::json s = solve_ok(obj, "--max-edge 0.5", &err);
  EXPECT_EQ(s["load"]["enclosure_faces_outward"], true);
  EXPECT_EQ(s["load"]["flipped_faces"], 0);  // consistent, only all the wrong way
  EXPECT_NE(err.find("faces outward"), std::string::npos) << err;
  EXPECT_NE(err.find("--flip-normals"), std::string::npos) << err;
  for (double b : cell_radiosity()) EXPECT_NEAR(b, 1.0, 1e-12);  // every wall sees only the outside

  const nlohmann::json fixed = solve_ok(obj, "--max-edge 0.5 --tolerance 1e-12 --flip-normals", &err);
  EXPECT_EQ(fixed["load"]["enclosure_faces_outward"], false);
  EXPECT_EQ(fixed["load"]["flipped_all"], true);
  EXPECT_EQ(err.find("warning"), std::string::npos) << err;
  for (double b : cell_radiosity()) EXPECT_NEAR(b, 2.0, 1e-9);
}

// Orientation is only decided on closed surfaces: elsewhere the winding does not say which side
// is meant, and nothing is flipped.
TEST_F(BadInput, OrientationOfOpenOrNonManifoldSurfacesIsLeftAlone) {
  write("furnace.mtl", kFurnaceMtl);
  std::string open_box = cube("", /*reversed_face=*/3);
  open_box.erase(open_box.find("f 5 8 7 6\n"), 10);  // no ceiling: open
  EXPECT_EQ(photometria::load_scene(write("open.obj", open_box)).stats.flipped_faces, 0);
  // A fin on the floor's edge 1-2: that edge has three faces.
  const std::string fin = cube("v 0.5 -1 0\nf 1 2 9\n", 3);
  EXPECT_EQ(photometria::load_scene(write("fin.obj", fin)).stats.flipped_faces, 0);
  // Two closed cubes side by side (not sharing vertices), one face flipped in each.
  std::string two = cube("", 3);
  two +=
      "v 2 0 0\nv 3 0 0\nv 3 1 0\nv 2 1 0\nv 2 0 1\nv 3 0 1\nv 3 1 1\nv 2 1 1\n"
      "f 9 10 11 12\nf 13 16 15 14\nf 14 10 9 13\nf 11 15 14 10\nf 11 15 16 12\nf 12 16 13 9\n";
  const photometria::Scene s = photometria::load_scene(write("two.obj", two));
  EXPECT_EQ(s.stats.flipped_faces, 2);
  EXPECT_FALSE(s.stats.enclosure_faces_outward);  // neither box holds the whole scene
}

// ----- interrupted runs -------------------------------------------------------------------------

// Starts a solve that runs for minutes, stops it with `sig` once it is under way and checks that
// neither the .vtu nor its temporary file is left.
void interrupt_long_solve(const fs::path& dir, int sig) {
  const std::string out = (dir / "long.vtu").string();
  const std::string scene = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    // A shell may start background jobs with SIGINT ignored; the CLI should see the default.
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    freopen("/dev/null", "w", stderr);
    execl(PHOTOMETRIA_BINARY, PHOTOMETRIA_BINARY, "solve", scene.c_str(), "-o", out.c_str(), "--max-edge", "0.1",
          "--visibility", "rays", "--rays", "64", "--threads", "1", "--quiet", static_cast<char*>(nullptr));
    _exit(127);
  }
  const std::string temp = out + ".tmp-" + std::to_string(pid);
  // The temporary file appears when the output is probed, before loading; give the run a
  // moment more so that the signal lands in the middle of the work.
  for (int i = 0; i < 1000 && !fs::exists(temp); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_TRUE(fs::exists(temp)) << "the solve did not start";
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(pid, sig);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << "status " << status;
  EXPECT_FALSE(fs::exists(temp));
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(BadInput, SigtermLeavesNoPartialOutput) { interrupt_long_solve(dir_, SIGTERM); }
TEST_F(BadInput, SigintLeavesNoPartialOutput) { interrupt_long_solve(dir_, SIGINT); }
