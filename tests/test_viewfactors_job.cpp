// The view-factor job (src/viewfactors/job.h) called directly on the shipped Cornell box: the
// result struct, the files it commits (all or nothing), the load warnings it hands back, and
// the JSON and text summaries built from it (src/viewfactors/report.h).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "scratch_dir.h"
#include "util/error.h"
#include "viewfactors/job.h"
#include "viewfactors/report.h"

using namespace photometria;
namespace fs = std::filesystem;

namespace {

const std::string kCornell = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj";

// The files in `dir`, by name.
std::set<std::string> files_in(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream s(text);
  std::string line;
  while (std::getline(s, line)) lines.push_back(line);
  return lines;
}

std::set<std::string> keys_of(const nlohmann::json& j) {
  std::set<std::string> keys;
  for (const auto& item : j.items()) keys.insert(item.key());
  return keys;
}

ViewFactorJob cornell_job(const fs::path& dir) {
  ViewFactorJob job;
  job.scene = kCornell;
  job.output = (dir / "vf.csv").string();
  return job;
}

// Looser per-pair rules than the defaults (1e-7, and the occluded pairs' default), for tests that
// compare two ways of writing the same factors: the bytes compared do not depend on the rules,
// the time (most of it under the sanitizers) does.
void loosen_the_rules(ViewFactorJob& job) {
  job.fill.accuracy = 1e-4;
  job.fill.occluded_accuracy = 1e-2;
}

// Two points: one on the floor facing up, one beside the left wall facing +x.
std::string write_points(const fs::path& dir) {
  const fs::path p = dir / "points.csv";
  std::ofstream(p) << "x,y,z,nx,ny,nz,id\n0,0.01,0,0,1,0,centre\n-0.9,1,0,1,0,0,left\n";
  return p.string();
}

const std::set<std::string> kAlwaysKeys = {"scene",
                                           "occluded_accuracy",
                                           "output",
                                           "format",
                                           "factors",
                                           "level",
                                           "surfaces",
                                           "patches",
                                           "faces",
                                           "accuracy",
                                           "visibility",
                                           "visibility_reason",
                                           "checks",
                                           "matrix",
                                           "memory_estimate",
                                           "pairs",
                                           "enforce",
                                           "seconds",
                                           "peak_memory_bytes",
                                           "ranks"};

}  // namespace

TEST(ViewFactorJob, FaceLevelCsvResultAndSummaries) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.level = AggregateLevel::Face;
  std::vector<std::string> warnings;
  job.on_load_warning = [&](const std::string& source, const std::string& w) {
    EXPECT_EQ(source, kCornell);
    warnings.push_back(w);
  };
  const ViewFactorJobResult r = run_view_factor_job(job);

  // The Cornell box: 18 input faces, one non-planar quad split into two triangles: 19 faces,
  // one patch each (no --max-edge), 18 rows (one per input face).
  EXPECT_EQ(r.faces, 19);
  EXPECT_EQ(r.patches, 19);
  ASSERT_EQ(r.surfaces(), 18);
  EXPECT_EQ(r.names.front(), "face 0");
  ASSERT_EQ(r.areas.size(), 18u);
  ASSERT_EQ(r.F.rows(), 18);
  ASSERT_EQ(r.F.cols(), 18);
  EXPECT_EQ(r.job.scene, kCornell);
  EXPECT_EQ(r.job.output, job.output);
  EXPECT_EQ(r.job.level, AggregateLevel::Face);
  EXPECT_EQ(r.job.format, ViewFactorFormat::Csv);
  EXPECT_EQ(r.job.fill.accuracy, 1e-7);
  EXPECT_EQ(r.job.fill.quadrature, 6);
  EXPECT_EQ(r.visibility_mode, "exact");
  EXPECT_FALSE(r.visibility_reason.empty());
  EXPECT_FALSE(r.matrix_storage.empty());
  EXPECT_GT(r.matrix_bytes, 0.0);
  EXPECT_GT(r.memory.estimated_bytes, 0.0);
  EXPECT_EQ(r.memory.limit_source, "MemAvailable");
  EXPECT_GT(r.fill.pairs_evaluated, 0);
  EXPECT_GT(r.fill.pairs_occluded, 0);  // the boxes block some pairs
  EXPECT_GE(r.seconds, 0.0);
  EXPECT_TRUE(r.job.points_output.empty());
  EXPECT_EQ(r.job.fill.points, 0);
  EXPECT_EQ(r.sparse.written, 0);
  EXPECT_EQ(r.enforcement_report.iterations, 0);
  // The checks are those of the returned matrix: an open box, rows sum to at most 1, up to the
  // estimated error of the occluded pairs' sum (adaptive to 1e-3 by default).
  EXPECT_GT(r.fill.pairs_occluded_adaptive, 0);
  EXPECT_LE(r.fill.max_row_error_estimate, 1e-3);
  EXPECT_LE(r.checks.max_row_sum, 1.0 + r.fill.max_row_error_estimate);
  EXPECT_NEAR(r.checks.max_row_sum, r.F.rowwise().sum().maxCoeff(), 1e-15);
  EXPECT_GE(r.checks.min_entry, 0.0);

  // Load warnings came back through the callback (the split face and the two flipped ones).
  EXPECT_EQ(warnings.size(), 2u);

  // Only the committed output is left, no temporary file.
  EXPECT_EQ(files_in(dir), std::set<std::string>{"vf.csv"});
  std::ifstream in(job.output);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("name,area,face 0,face 1,", 0), 0u) << header;

  const nlohmann::json j = viewfactor_summary_json(r);
  EXPECT_EQ(keys_of(j), kAlwaysKeys);
  EXPECT_EQ(j["format"], "csv");
  EXPECT_EQ(j["factors"], "geometric");
  EXPECT_EQ(j["level"], "face");
  EXPECT_EQ(j["enforce"], "none");
  EXPECT_EQ(j["surfaces"], 18);
  EXPECT_EQ(j["patches"], 19);
  EXPECT_EQ(j["checks"]["worst_row_name"], r.names[static_cast<size_t>(r.checks.worst_row)]);
  EXPECT_EQ(j["checks"]["row_sum_max"].get<double>(), r.checks.max_row_sum);
  EXPECT_EQ(j["pairs"]["fixed_rule_order"], 6);
  EXPECT_EQ(j["matrix"]["storage"], r.matrix_storage);
  EXPECT_EQ(j["seconds"].get<double>(), r.seconds);

  const std::vector<std::string> lines = lines_of(viewfactor_summary_text(r));
  ASSERT_EQ(lines.size(), 9u) << viewfactor_summary_text(r);
  EXPECT_EQ(lines[0], "view factors: 18 faces from 19 patches -> " + job.output + " (csv)");
  EXPECT_EQ(lines[1], "  visibility: exact (" + r.visibility_reason + ")");
  const std::vector<std::string> starts = {"  row sums: min ",
                                           "  reciprocity error max: ",
                                           "  matrix: " + r.matrix_storage + ", ",
                                           "  memory estimate: ",
                                           "  pairs: ",
                                           "  occluded pairs: ",
                                           "  time "};
  for (size_t i = 0; i < starts.size(); ++i) EXPECT_EQ(lines[i + 2].rfind(starts[i], 0), 0u) << lines[i + 2];
  EXPECT_NE(lines[8].find(" s, peak memory "), std::string::npos);
}

TEST(ViewFactorJob, SparseEnforcedWithPoints) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.output = (dir / "vf.txt").string();
  job.format = ViewFactorFormat::Sparse;
  job.threshold = 1e-3;
  job.enforcement = Enforcement::Both;
  job.points = write_points(dir);
  job.fill.max_memory_bytes = 1 << 30;
  const ViewFactorJobResult r = run_view_factor_job(job);

  ASSERT_EQ(r.surfaces(), 8);  // the groups of the OBJ file
  EXPECT_EQ(r.job.fill.points, 2);
  EXPECT_EQ(r.job.points_output, job.output + ".points.csv");
  EXPECT_EQ(r.memory.limit_bytes, double(1 << 30));
  EXPECT_EQ(r.memory.limit_source, "--max-memory");
  // Both: reciprocal and closed afterwards.
  EXPECT_GT(r.enforcement_report.before.reciprocity_error, 1e-5);
  EXPECT_LT(r.enforcement_report.after.reciprocity_error, 1e-12);
  EXPECT_NEAR(r.checks.min_row_sum, 1.0, 1e-12);
  EXPECT_NEAR(r.checks.max_row_sum, 1.0, 1e-12);
  EXPECT_GT(r.sparse.written, 0);
  EXPECT_EQ(r.sparse.written + r.sparse.dropped, (r.F.array() > 0.0).count());

  EXPECT_EQ(files_in(dir), (std::set<std::string>{"points.csv", "vf.txt", "vf.txt.points.csv"}));

  const nlohmann::json j = viewfactor_summary_json(r);
  std::set<std::string> want = kAlwaysKeys;
  want.insert({"enforcement", "sparse", "points"});
  EXPECT_EQ(keys_of(j), want);
  EXPECT_EQ(j["format"], "sparse");
  EXPECT_EQ(j["level"], "group");
  EXPECT_EQ(j["enforce"], "both");
  EXPECT_EQ(keys_of(j["enforcement"]), (std::set<std::string>{"before", "after", "iterations", "max_change"}));
  EXPECT_EQ(j["sparse"]["threshold"].get<double>(), 1e-3);
  EXPECT_EQ(j["sparse"]["written"], r.sparse.written);
  EXPECT_EQ(j["points"]["count"], 2);
  EXPECT_EQ(j["points"]["output"], r.job.points_output);
  EXPECT_EQ(j["memory_estimate"]["limit_source"], "--max-memory");

  const std::vector<std::string> lines = lines_of(viewfactor_summary_text(r));
  ASSERT_EQ(lines.size(), 12u) << viewfactor_summary_text(r);
  EXPECT_EQ(lines[0], "view factors: 8 groups from 19 patches -> " + job.output + " (sparse)");
  EXPECT_EQ(lines[7].rfind("  occluded pairs: ", 0), 0u) << lines[7];
  EXPECT_EQ(lines[8].rfind("  enforcement both: reciprocity error ", 0), 0u) << lines[8];
  EXPECT_EQ(lines[9].rfind("  sparse: " + std::to_string(r.sparse.written) + " entries written, ", 0), 0u) << lines[9];
  EXPECT_NE(lines[9].find(" below 0.001 dropped"), std::string::npos) << lines[9];
  EXPECT_EQ(lines[10], "  point factors: 2 points -> " + r.job.points_output);
  EXPECT_EQ(lines[11].rfind("  time ", 0), 0u);
}

// Sparse rows written while they are filled (--stream): the same bytes and checks as the stored
// matrix's, save the reciprocity error, which needs both triangles at once.
TEST(ViewFactorJob, StreamedSparseRowsAreTheStoredOnesByteForByte) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.level = AggregateLevel::Patch;
  job.format = ViewFactorFormat::Sparse;
  job.threshold = 1e-4;
  job.fill.patching.max_edge = 0.45;
  job.fill.threads = 2;  // rows arrive out of order
  loosen_the_rules(job);
  job.output = (dir / "stored.txt").string();
  job.stream = RowStreaming::No;
  const ViewFactorJobResult stored = run_view_factor_job(job);
  job.output = (dir / "streamed.txt").string();
  job.stream = RowStreaming::Yes;
  const ViewFactorJobResult streamed = run_view_factor_job(job);

  ASSERT_GT(streamed.patches, 100);
  EXPECT_FALSE(stored.streamed);
  EXPECT_EQ(stored.stream_reason, "requested (--stream no)");
  EXPECT_TRUE(streamed.streamed);
  EXPECT_EQ(streamed.stream_reason, "requested (--stream yes)");
  EXPECT_EQ(streamed.F.size(), 0);
  EXPECT_EQ(streamed.matrix_storage, "streamed");
  EXPECT_EQ(streamed.memory.matrix_bytes, 0.0);
  EXPECT_EQ(streamed.memory.output_bytes, 0.0);
  EXPECT_LT(streamed.memory.estimated_bytes, stored.memory.estimated_bytes / 4);

  std::ifstream a(dir / "stored.txt"), b(dir / "streamed.txt");
  const std::string stored_text((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
  const std::string streamed_text((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
  EXPECT_GT(stored_text.size(), 100000u);
  EXPECT_TRUE(stored_text == streamed_text) << "the streamed file differs from the stored one";

  EXPECT_EQ(streamed.sparse.written, stored.sparse.written);
  EXPECT_EQ(streamed.sparse.dropped, stored.sparse.dropped);
  EXPECT_GT(streamed.sparse.dropped, 0);
  EXPECT_EQ(streamed.sparse.worst_row, stored.sparse.worst_row);
  EXPECT_EQ(streamed.sparse.max_dropped_row_sum, stored.sparse.max_dropped_row_sum);
  EXPECT_EQ(streamed.sparse.total_dropped, stored.sparse.total_dropped);
  EXPECT_EQ(streamed.checks.min_row_sum, stored.checks.min_row_sum);
  EXPECT_EQ(streamed.checks.max_row_sum, stored.checks.max_row_sum);
  EXPECT_EQ(streamed.checks.mean_row_sum, stored.checks.mean_row_sum);
  EXPECT_EQ(streamed.checks.worst_row, stored.checks.worst_row);
  EXPECT_EQ(streamed.checks.min_entry, stored.checks.min_entry);
  EXPECT_EQ(streamed.checks.max_entry, stored.checks.max_entry);
  EXPECT_TRUE(stored.checks.reciprocity_checked);
  EXPECT_GT(stored.checks.reciprocity_error, 0.0);
  EXPECT_FALSE(streamed.checks.reciprocity_checked);

  const nlohmann::json j = viewfactor_summary_json(streamed);
  EXPECT_TRUE(j["checks"]["reciprocity_error_max"].is_null());
  EXPECT_EQ(j["sparse"]["streamed"], true);
  EXPECT_EQ(j["matrix"]["storage"], "streamed");
  EXPECT_EQ(viewfactor_summary_json(stored)["sparse"]["streamed"], false);
  const std::string text = viewfactor_summary_text(streamed);
  EXPECT_NE(text.find("  reciprocity error max: not checked (the rows were streamed"), std::string::npos) << text;
  EXPECT_NE(text.find("; rows streamed (requested (--stream yes))"), std::string::npos) << text;
}

// Every form streams (--stream yes) to the same bytes as the stored matrix's: the dense CSV, the
// binary matrix and View3D's layout with its trailing emissivities, rows arriving out of order.
TEST(ViewFactorJob, StreamedRowsOfEveryFormAreTheStoredOnesByteForByte) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.level = AggregateLevel::Patch;
  job.fill.patching.max_edge = 0.45;
  job.fill.threads = 2;
  loosen_the_rules(job);
  for (ViewFactorFormat format : {ViewFactorFormat::Csv, ViewFactorFormat::Binary, ViewFactorFormat::View3d}) {
    const std::string name = view_factor_format_name(format);
    job.format = format;
    job.output = (dir / ("stored." + name)).string();
    job.stream = RowStreaming::No;
    const ViewFactorJobResult stored = run_view_factor_job(job);
    job.output = (dir / ("streamed." + name)).string();
    job.stream = RowStreaming::Yes;
    const ViewFactorJobResult streamed = run_view_factor_job(job);
    ASSERT_TRUE(streamed.streamed) << name;
    ASSERT_FALSE(stored.streamed) << name;
    EXPECT_EQ(streamed.F.size(), 0) << name;
    std::ifstream a(dir / ("stored." + name), std::ios::binary), b(dir / ("streamed." + name), std::ios::binary);
    const std::string stored_bytes((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
    const std::string streamed_bytes((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
    EXPECT_GT(stored_bytes.size(), size_t(streamed.patches) * size_t(streamed.patches)) << name;
    EXPECT_TRUE(stored_bytes == streamed_bytes) << name << ": the streamed file differs from the stored one";
    EXPECT_EQ(streamed.checks.max_row_sum, stored.checks.max_row_sum) << name;
    EXPECT_EQ(streamed.checks.worst_row, stored.checks.worst_row) << name;
    const nlohmann::json j = viewfactor_summary_json(streamed);
    EXPECT_EQ(j["matrix"]["streamed"], true) << name;
    EXPECT_EQ(j["matrix"]["stream_reason"], "requested (--stream yes)") << name;
    EXPECT_FALSE(j.contains("sparse")) << name;
  }
}

// Auto streams when the stored matrix would not fit the memory limit, or when nothing blocks and
// the rows' closed forms mirror in bands within it; otherwise it stores. `no` is refused by the
// memory check where the matrix does not fit, and `yes` where the output needs the whole matrix.
TEST(ViewFactorJob, StreamingAutoFollowsTheMemoryLimit) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.level = AggregateLevel::Patch;
  job.format = ViewFactorFormat::Sparse;
  job.fill.threads = 2;
  const ViewFactorJobResult occluded = run_view_factor_job(job);  // the Cornell box: blocks inside
  EXPECT_FALSE(occluded.streamed);
  EXPECT_EQ(occluded.stream_reason, "auto: the matrix fits the memory limit, stored");

  job.scene = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/furnace_cube.obj";  // convex: a quick fill
  job.fill.patching.max_edge = 0.1;
  job.stream = RowStreaming::No;
  const ViewFactorJobResult roomy = run_view_factor_job(job);
  EXPECT_FALSE(roomy.streamed);
  job.stream = RowStreaming::Auto;
  const ViewFactorJobResult mirrored = run_view_factor_job(job);
  EXPECT_TRUE(mirrored.streamed);
  EXPECT_EQ(mirrored.stream_reason.rfind("auto: nothing blocks and the closed forms mirror in bands", 0), 0u)
      << mirrored.stream_reason;
  EXPECT_TRUE(mirrored.fill.mirrored);
  EXPECT_TRUE(mirrored.checks.reciprocity_checked);
  EXPECT_EQ(mirrored.sparse.written, roomy.sparse.written);
  // N = 600 patches: the stored matrix and its copy take about 5.8 MB, streamed rows < 1 MB, and
  // the mirrored bands' blocks about 3.2 MB.
  ASSERT_EQ(roomy.patches, 600);
  job.fill.max_memory_bytes = 4 << 20;
  const ViewFactorJobResult tight = run_view_factor_job(job);
  EXPECT_TRUE(tight.streamed);
  EXPECT_EQ(tight.stream_reason.rfind("auto: the stored matrix and its output copy need an estimated ", 0), 0u)
      << tight.stream_reason;
  EXPECT_LE(tight.memory.estimated_bytes, job.fill.max_memory_bytes);
  EXPECT_EQ(tight.sparse.written, roomy.sparse.written);
  EXPECT_EQ(tight.checks.max_row_sum, roomy.checks.max_row_sum);

  job.stream = RowStreaming::No;
  try {
    run_view_factor_job(job);
    ADD_FAILURE() << "a matrix over --max-memory was stored";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("but --max-memory is 4 MiB"), std::string::npos) << e.what();
  }
  job.stream = RowStreaming::Yes;
  job.fill.max_memory_bytes = 0;
  for (const auto& [format, level, enforcement, why] :
       {std::tuple{ViewFactorFormat::Sparse, AggregateLevel::Group, Enforcement::None, "--by group sums rows"},
        std::tuple{ViewFactorFormat::Sparse, AggregateLevel::Face, Enforcement::None, "a face is split"},
        std::tuple{ViewFactorFormat::Csv, AggregateLevel::Patch, Enforcement::Both, "--enforce needs"}}) {
    job.format = format;
    job.level = level;
    job.enforcement = enforcement;
    try {
      run_view_factor_job(job);
      ADD_FAILURE() << "streamed: " << why;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_EQ(std::string(e.what()).rfind(std::string("--stream yes: ") + why, 0), 0u) << e.what();
    }
  }
  EXPECT_EQ(files_in(dir), std::set<std::string>{"vf.csv"});  // from the runs that worked
}

// Streamed rows still have a memory estimate (the per-patch arrays and the rows in flight):
// over --max-memory, the run is refused in one line before the fill, and nothing is written.
TEST(ViewFactorJob, StreamedRowsOverTheLimitAreRefused) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.scene = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/furnace_cube.obj";
  job.level = AggregateLevel::Patch;
  job.format = ViewFactorFormat::Binary;
  job.fill.patching.max_edge = 0.1;
  job.stream = RowStreaming::Yes;
  job.fill.max_memory_bytes = 64 << 10;
  try {
    run_view_factor_job(job);
    ADD_FAILURE() << "streamed over --max-memory";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    const std::string what = e.what();
    EXPECT_NE(what.find("for 600 patches (rows streamed, 600 output surfaces) but --max-memory is 64 KiB"),
              std::string::npos)
        << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(ViewFactorJob, PointsOutputCannotBeTheMatrixOutput) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.points = write_points(dir);
  job.points_output = (dir / "." / "vf.csv").string();
  bool warned = false;
  job.on_load_warning = [&](const std::string&, const std::string&) { warned = true; };
  try {
    run_view_factor_job(job);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("is also the -o output"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(warned);  // refused before the scene is loaded
  EXPECT_EQ(files_in(dir), std::set<std::string>{"points.csv"});
}

TEST(ViewFactorJob, AllOrNothingOnAnUnwritablePointsOutput) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.points = write_points(dir);
  job.points_output = (dir / "no_such_dir" / "p.csv").string();
  try {
    run_view_factor_job(job);
    FAIL() << "no error";
  } catch (const Error& e) { EXPECT_EQ(e.kind(), ErrorKind::Io); }
  EXPECT_EQ(files_in(dir), std::set<std::string>{"points.csv"});  // no matrix, no temporary
}

TEST(ViewFactorJob, MissingPointsFileFailsAfterTheWarningsAndLeavesNothing) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job = cornell_job(dir);
  job.points = (dir / "none.csv").string();
  int warnings = 0;
  job.on_load_warning = [&](const std::string&, const std::string&) { ++warnings; };
  EXPECT_THROW(run_view_factor_job(job), Error);
  EXPECT_EQ(warnings, 2);  // delivered as the scene loaded, before the error
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(ViewFactorJob, NamesRoundTrip) {
  for (AggregateLevel l : {AggregateLevel::Group, AggregateLevel::Face, AggregateLevel::Patch}) {
    AggregateLevel back = AggregateLevel::Group;
    EXPECT_TRUE(aggregate_level_from_name(aggregate_level_name(l), back));
    EXPECT_EQ(back, l);
  }
  for (Enforcement e : {Enforcement::None, Enforcement::Reciprocity, Enforcement::Closure, Enforcement::Both}) {
    Enforcement back = Enforcement::None;
    EXPECT_TRUE(enforcement_from_name(enforcement_name(e), back));
    EXPECT_EQ(back, e);
  }
  for (ViewFactorFormat f :
       {ViewFactorFormat::Csv, ViewFactorFormat::Sparse, ViewFactorFormat::Binary, ViewFactorFormat::View3d}) {
    ViewFactorFormat back = ViewFactorFormat::Csv;
    EXPECT_TRUE(view_factor_format_from_name(view_factor_format_name(f), back));
    EXPECT_EQ(back, f);
  }
  AggregateLevel l;
  Enforcement e;
  ViewFactorFormat f;
  EXPECT_FALSE(aggregate_level_from_name("Group", l));
  EXPECT_FALSE(enforcement_from_name("", e));
  EXPECT_FALSE(view_factor_format_from_name("vs3", f));
}

// A .vs3 with C emit=1 (tests/data/view3d_box_emit.vs3): the job writes Hottel's exchange
// factors of the enforced geometric factors, keeps the latter's checks, and the memory estimate
// counts the solve's matrices.
TEST(ViewFactorJob, EmitOneGivesExchangeFactorsOfTheEnforcedMatrix) {
  const fs::path dir = test_scratch::fresh_dir("photometria_vfjob_");
  ViewFactorJob job;
  job.scene = std::string(PHOTOMETRIA_SOURCE_DIR) + "/tests/data/view3d_box_emit.vs3";
  job.output = (dir / "sf.csv").string();
  job.enforcement = Enforcement::Both;
  const ViewFactorJobResult r = run_view_factor_job(job);
  EXPECT_TRUE(r.exchange_factors);
  EXPECT_TRUE(r.job.fill.exchange_factors);
  EXPECT_EQ(r.emissivities, (std::vector<double>{0.9, 0.3, 0.5, 0.7, 0.1, 0.6}));
  ASSERT_EQ(r.F.rows(), 6);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(r.F.row(i).sum(), r.emissivities[size_t(i)], 1e-14) << i;
  EXPECT_NEAR(r.geometric_checks.min_row_sum, 1.0, 1e-14);
  EXPECT_NEAR(r.geometric_checks.max_row_sum, 1.0, 1e-14);
  EXPECT_NEAR(r.checks.min_row_sum, 0.1, 1e-14);
  EXPECT_LE(r.checks.reciprocity_error, 1e-15);
  EXPECT_GT(r.F(0, 0), 0.2);  // the floor absorbs back 0.2337 of its own emission (View3D: 0.233726)
  EXPECT_EQ(r.memory.output_bytes, 8.0 * 36 * (1 + 4 + 3));
  const nlohmann::json j = viewfactor_summary_json(r);
  EXPECT_EQ(j["factors"], "script-F");
  EXPECT_EQ(j["exchange"]["source"], "C emit=1");
  EXPECT_EQ(j["exchange"]["geometric_checks"]["row_sum_max"].get<double>(), r.geometric_checks.max_row_sum);
  const std::string text = viewfactor_summary_text(r);
  EXPECT_NE(text.find("\n  script-F (C emit=1): Hottel's total exchange factors"), std::string::npos) << text;

  // The same file without emit: the geometric factors (the job is otherwise the same).
  const fs::path plain = dir / "box.vs3";
  {
    std::ifstream in(job.scene);
    std::ofstream out(plain);
    for (std::string line; std::getline(in, line);) out << (line.rfind("C ", 0) == 0 ? "C encl=1" : line) << "\n";
  }
  job.scene = plain.string();
  const ViewFactorJobResult g = run_view_factor_job(job);
  EXPECT_FALSE(g.exchange_factors);
  EXPECT_NEAR(g.F.row(0).sum(), 1.0, 1e-14);
  EXPECT_EQ(g.F(0, 0), 0.0);
  EXPECT_EQ(g.checks.min_row_sum, r.geometric_checks.min_row_sum);
}
