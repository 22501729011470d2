// src/distributed: the row partition, the pieces of a shared file, the ranks of one process, and
// `mpirun -np R photometria viewfactors` against one process (when the build has MPI).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>

#include <nlohmann/json.hpp>
#include "cli_run.h"
#include "distributed/ranks.h"
#include "distributed/row_partition.h"
#include "distributed/shared_file.h"
#include "io/vtu.h"
#include "patching/patching.h"
#include "scene_builders.h"
#include "scratch_dir.h"
#include "util/error.h"

namespace pm = photometria;
namespace fs = std::filesystem;

namespace {

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Points on a 8 × 8 × 8 grid, in scrambled order.
std::vector<pm::Vec3> grid_points() {
  std::vector<pm::Vec3> p;
  for (int k = 0; k < 512; ++k) {
    const int m = (k * 307) % 512;
    p.emplace_back(m % 8, (m / 8) % 8, m / 64);
  }
  return p;
}

}  // namespace

TEST(MortonOrder, VisitsEveryPointOnceAndKeepsOctantsTogether) {
  const std::vector<pm::Vec3> p = grid_points();
  const std::vector<int> order = pm::morton_order(p);
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (int k = 0; k < 512; ++k) EXPECT_EQ(sorted[size_t(k)], k);
  // A Z-order curve on a 2^3 grid of 8^3 points visits each of the 8 octants (4 × 4 × 4 points)
  // in one run of 64.
  for (int run = 0; run < 8; ++run) {
    const pm::Vec3 first = p[size_t(order[size_t(run * 64)])];
    for (int k = run * 64; k < run * 64 + 64; ++k) {
      const pm::Vec3 q = p[size_t(order[size_t(k)])];
      EXPECT_EQ(int(q.x()) / 4, int(first.x()) / 4);
      EXPECT_EQ(int(q.y()) / 4, int(first.y()) / 4);
      EXPECT_EQ(int(q.z()) / 4, int(first.z()) / 4);
    }
  }
}

TEST(PartitionRows, EveryRowOnceInCurveOrderBalancedByCost) {
  const std::vector<pm::Vec3> p = grid_points();
  std::vector<double> cost(p.size());
  for (size_t i = 0; i < p.size(); ++i) cost[i] = 1.0 + double(i % 7);  // uneven rows
  const double total = std::accumulate(cost.begin(), cost.end(), 0.0);
  const double largest = *std::max_element(cost.begin(), cost.end());
  const std::vector<int> curve = pm::morton_order(p);
  std::vector<int> position(p.size());
  for (size_t k = 0; k < curve.size(); ++k) position[size_t(curve[k])] = int(k);
  for (int chunks : {1, 4, 16}) {
    for (int parts : {1, 2, 3, 4, 7}) {
      const std::vector<std::vector<int>> split = pm::partition_rows(p, cost, parts, chunks);
      ASSERT_EQ(split.size(), size_t(parts));
      std::vector<int> all;
      for (const std::vector<int>& part : split) {
        double c = 0.0;
        for (int i : part) c += cost[size_t(i)];
        // Cut at the rows' midpoints: each chunk within one row's cost of its share.
        EXPECT_NEAR(c, total / parts, chunks * largest) << parts << " parts of " << chunks << " chunks";
        // In curve order within the part.
        for (size_t k = 1; k < part.size(); ++k) EXPECT_LT(position[size_t(part[k - 1])], position[size_t(part[k])]);
        all.insert(all.end(), part.begin(), part.end());
      }
      // One chunk per part: the parts, concatenated, are the Morton order itself (contiguous runs).
      if (chunks == 1) { EXPECT_EQ(all, curve) << parts << " parts"; }
      std::sort(all.begin(), all.end());
      for (size_t k = 0; k < all.size(); ++k) ASSERT_EQ(all[k], int(k)) << "every row exactly once";
    }
  }
  // Chunks dealt in turn: with 2 parts of 4 chunks, part 0 holds the curve's 1st, 3rd, 5th and
  // 7th eighths (equal costs here).
  const std::vector<double> flat(p.size(), 1.0);
  const std::vector<std::vector<int>> dealt = pm::partition_rows(p, flat, 2, 4);
  for (int i : dealt[0]) EXPECT_EQ(position[size_t(i)] / 64 % 2, 0);
  for (int i : dealt[1]) EXPECT_EQ(position[size_t(i)] / 64 % 2, 1);
  // More parts than rows: some parts are empty, no row is lost.
  const std::vector<std::vector<int>> many = pm::partition_rows({pm::Vec3(0, 0, 0), pm::Vec3(1, 0, 0)}, {1.0, 1.0}, 5);
  size_t rows = 0;
  for (const std::vector<int>& part : many) rows += part.size();
  EXPECT_EQ(rows, 2u);
}

TEST(EstimateRowCosts, CountsTheFacingSourcesOfACube) {
  // The inside of a unit cube, one patch per wall: each wall faces the other five (the sample is
  // every patch when there are fewer than kCostSample).
  const pm::PatchMesh mesh = pm::subdivide(builders::unit_cube(), pm::PatchingOptions{});
  const std::vector<double> cost = pm::estimate_row_costs(mesh);
  ASSERT_EQ(cost.size(), 6u);
  for (double c : cost) EXPECT_DOUBLE_EQ(c, 1.0 + 5.0);  // the opposite wall and the four beside it
}

TEST(WritePieces, OneProcessPlacesEveryPieceAtItsOffset) {
  const fs::path dir = test_scratch::fresh_dir("distributed_pieces");
  const std::string path = (dir / "out.bin").string();
  { std::ofstream(path) << "old contents that are longer than the new file"; }
  const std::string a = "alpha,", b = "", c = "gamma\n";
  // Pieces given out of order, one of them empty, one index held by nobody.
  pm::write_pieces(path, "target.csv", "HEAD\n", {{2, &c}, {0, &a}, {1, &b}}, 4, "TAIL\n");
  // The pieces overwrite the file's start; its old tail is the caller's (a fresh temporary file).
  EXPECT_EQ(read_bytes(path).substr(0, 22), "HEAD\nalpha,gamma\nTAIL\n");
  fs::remove_all(dir);
}

TEST(WritePieces, AMissingFileIsAnIoErrorNamingTheTarget) {
  try {
    const std::string piece = "x";
    pm::write_pieces("/nonexistent-folder/part.tmp", "result.csv", "", {{0, &piece}}, 1, "");
    FAIL() << "no error";
  } catch (const pm::Error& e) {
    EXPECT_EQ(e.kind(), pm::ErrorKind::Io);
    EXPECT_NE(std::string(e.what()).find("cannot write 'result.csv'"), std::string::npos) << e.what();
  }
}

TEST(Ranks, OneProcessIsRankZeroOfOne) {
  EXPECT_EQ(pm::ranks::size(), 1);
  EXPECT_EQ(pm::ranks::rank(), 0);
  EXPECT_FALSE(pm::ranks::distributed());
  std::vector<double> v = {1.5, 2.5};
  pm::ranks::sum(v);
  EXPECT_EQ(v, (std::vector<double>{1.5, 2.5}));
  EXPECT_EQ(pm::ranks::all_values(3.0), std::vector<double>{3.0});
  EXPECT_NO_THROW(pm::ranks::agree(nullptr));
  EXPECT_THROW(pm::ranks::agree(std::make_exception_ptr(pm::Error(pm::ErrorKind::Io, "x"))), pm::Error);
}

#ifdef PHOTOMETRIA_MPIEXEC

namespace {

// `mpirun -np R photometria ARGS`, allowed as root and on more ranks than cores (Open MPI reads
// these variables; other MPIs ignore them).
cli_test::CliRun run_ranks(int ranks, const std::string& args, const std::string& err_file,
                           const std::string& binary = PHOTOMETRIA_BINARY) {
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  setenv("OMPI_MCA_rmaps_base_oversubscribe", "1", 1);
  return cli_test::run_command(
      std::string(PHOTOMETRIA_MPIEXEC) + " -np " + std::to_string(ranks) + " " + binary + " " + args, err_file);
}

const std::string kRoom = std::string(PHOTOMETRIA_SOURCE_DIR) + "/tests/data/room_faces_05.vs3";
const std::string kFast = " --by face --occluded-accuracy 1e-2 --quiet";

// Lines of ours on stderr (mpirun adds its own report of a rank's non-zero exit).
int lines(const std::string& s) {
  int n = 0;
  for (size_t at = s.find("photometria:"); at != std::string::npos; at = s.find("photometria:", at + 1)) ++n;
  return n;
}

}  // namespace

// The same bytes on 1, 2 and 4 ranks as one process's streamed run, in every form: each row is
// computed the same wherever it is filled, and every rank's rows land at their offsets.
TEST(MpiViewFactors, TheSameBytesOnAnyNumberOfRanks) {
  const fs::path dir = test_scratch::fresh_dir("distributed_mpi_bytes");
  const auto file = [&](const std::string& name) { return (dir / name).string(); };
  struct Form {
    std::string name, args;
  };
  for (const Form& form : {Form{"binary", "--format binary"}, Form{"csv", "--format csv"},
                           Form{"sparse", "--format sparse --threshold 1e-4"}, Form{"view3d", "--format view3d"}}) {
    const std::string one = file("one." + form.name);
    const cli_test::CliRun single = cli_test::run_cli(
        "viewfactors " + kRoom + kFast + " --stream yes " + form.args + " -o " + one + " --json", file("err"));
    ASSERT_EQ(single.exit_code, 0) << single.err;
    const std::string expected = read_bytes(one);
    ASSERT_GT(expected.size(), 1000u);
    for (int ranks : {1, 2, 4}) {
      if (ranks != 2 && form.name != "binary" && form.name != "sparse") continue;  // (time)
      const std::string out = file("r" + std::to_string(ranks) + "." + form.name);
      const cli_test::CliRun r = run_ranks(ranks,
                                           "viewfactors " + kRoom + kFast + " " + form.args + " -o " + out + " --json" +
                                               (ranks == 1 ? " --stream yes" : ""),  // (one rank stores by default)
                                           file("err"));
      ASSERT_EQ(r.exit_code, 0) << form.name << " on " << ranks << " ranks: " << r.err;
      EXPECT_TRUE(read_bytes(out) == expected) << form.name << " on " << ranks << " ranks differs";
      // One summary (rank 0's), with the ranks and the same checks and counts as one process.
      const nlohmann::json j = nlohmann::json::parse(r.out);
      const nlohmann::json s = nlohmann::json::parse(single.out);
      EXPECT_EQ(j["ranks"]["count"], ranks);
      EXPECT_EQ(j["checks"], s["checks"]);
      EXPECT_EQ(j["pairs"], s["pairs"]);
      if (form.name == "sparse") { EXPECT_EQ(j["sparse"]["dropped_row_sum_max"], s["sparse"]["dropped_row_sum_max"]); }
      if (ranks > 1) {
        const std::vector<int> rows = j["ranks"]["rows_per_rank"];
        EXPECT_EQ(std::accumulate(rows.begin(), rows.end(), 0), 302);
        EXPECT_GE(j["ranks"]["load_imbalance"].get<double>(), 1.0);
      }
    }
  }
  fs::remove_all(dir);
}

TEST(MpiViewFactors, AnUnwritableOutputEndsEveryRankWithOneMessage) {
  const cli_test::CliRun r =
      run_ranks(2, "viewfactors " + kRoom + kFast + " -o /nonexistent-folder/F.csv", "/tmp/pm_mpi_err.txt");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("photometria: cannot write '/nonexistent-folder/F.csv'"), std::string::npos) << r.err;
  EXPECT_EQ(lines(r.err), 1) << r.err;
}

TEST(MpiViewFactors, WhatCannotBeStreamedIsRefusedOnRanks) {
  const fs::path dir = test_scratch::fresh_dir("distributed_mpi_refused");
  const auto file = [&](const std::string& name) { return (dir / name).string(); };
  const std::string out = file("F.csv");
  const cli_test::CliRun group = run_ranks(2, "viewfactors " + kRoom + " --by group -o " + out, file("err"));
  EXPECT_EQ(group.exit_code, 1) << group.err;
  EXPECT_NE(group.err.find("on several MPI ranks the rows are written as they are filled"), std::string::npos)
      << group.err;
  EXPECT_NE(group.err.find("--by group"), std::string::npos) << group.err;
  EXPECT_EQ(lines(group.err), 1) << group.err;
  EXPECT_FALSE(fs::exists(out));
  for (const auto& entry : fs::directory_iterator(dir)) ADD_FAILURE() << "left behind: " << entry.path();

  // The memory check is per rank, before the fill; --stream no cannot be honoured on ranks.
  const cli_test::CliRun memory =
      run_ranks(2, "viewfactors " + kRoom + " --by face --max-memory 100K -o " + out, file("err"));
  EXPECT_EQ(memory.exit_code, 1) << memory.err;
  EXPECT_NE(memory.err.find("--max-memory is 100 KiB"), std::string::npos) << memory.err;
  EXPECT_EQ(lines(memory.err), 1) << memory.err;
  const cli_test::CliRun stored =
      run_ranks(2, "viewfactors " + kRoom + " --by face --stream no -o " + out, file("err"));
  EXPECT_EQ(stored.exit_code, 1) << stored.err;
  EXPECT_NE(stored.err.find("--stream no: on several MPI ranks"), std::string::npos) << stored.err;
  EXPECT_FALSE(fs::exists(out));

  const std::string cornell = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj";
  const cli_test::CliRun validate = run_ranks(2, "validate --quick", file("err"));
  EXPECT_EQ(validate.exit_code, 1) << validate.err;
  EXPECT_NE(validate.err.find("'validate' runs as one process"), std::string::npos) << validate.err;
  EXPECT_EQ(lines(validate.err), 1) << validate.err;
  fs::remove_all(dir);
}

namespace {

const pm::VtuArray& array_named(const std::vector<pm::VtuArray>& arrays, const std::string& name) {
  for (const pm::VtuArray& a : arrays)
    if (a.name == name) return a;
  throw std::runtime_error("no array " + name);
}

// The largest |a − b| / max|b| over two arrays of the same size.
double relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double most = 0.0, scale = 0.0;
  for (size_t k = 0; k < b.size(); ++k) {
    most = std::max(most, std::abs(a[k] - b[k]));
    scale = std::max(scale, std::abs(b[k]));
  }
  return scale > 0.0 ? most / scale : most;
}

}  // namespace

namespace {

// `solve` of the Cornell box with `solver_args` on 1, 2 and 4 ranks against one process: every
// array agrees to 1e-12 relative (the figure), converged tightly, and one summary
// reports the ranks and the method that ran.
void expect_the_same_solve_on_ranks(const std::string& scratch, const std::string& solver_args,
                                    const std::string& method) {
  const fs::path dir = test_scratch::fresh_dir(scratch);
  const auto file = [&](const std::string& name) { return (dir / name).string(); };
  const std::string cornell = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj";
  const std::string args = " --max-edge 0.2 --tolerance 1e-14 --quiet --json " + solver_args;
  const cli_test::CliRun single = cli_test::run_cli("solve " + cornell + args + " -o " + file("one.vtu"), file("err"));
  ASSERT_EQ(single.exit_code, 0) << single.err;
  const pm::VtuGrid expected = pm::read_vtu(file("one.vtu"));
  const nlohmann::json s = nlohmann::json::parse(single.out);
  for (int ranks : {1, 2, 4}) {
    const std::string out = file("r" + std::to_string(ranks) + ".vtu");
    const cli_test::CliRun r = run_ranks(ranks, "solve " + cornell + args + " -o " + out, file("err"));
    ASSERT_EQ(r.exit_code, 0) << ranks << " ranks: " << r.err;
    const pm::VtuGrid g = pm::read_vtu(out);
    ASSERT_EQ(g.points.size(), expected.points.size());
    for (const std::string name : {"radiosity", "irradiance"}) {
      EXPECT_LE(relative_difference(array_named(g.point_arrays, name).values,
                                    array_named(expected.point_arrays, name).values),
                1e-12)
          << name << " at the points, " << ranks << " ranks";
      EXPECT_LE(
          relative_difference(array_named(g.cell_arrays, name).values, array_named(expected.cell_arrays, name).values),
          1e-12)
          << name << " per patch, " << ranks << " ranks";
    }
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["ranks"]["count"], ranks);
    EXPECT_EQ(j["solver"]["method"], method) << ranks << " ranks";
    if (ranks > 1) {
      const std::string detail = j["solver"]["detail"];
      EXPECT_NE(detail.find(method == "gmres" ? "PETSc GMRES" : "Gauss–Seidel"), std::string::npos) << detail;
    }
    EXPECT_TRUE(j["solver"]["converged"].get<bool>());
    EXPECT_LE(j["solver"]["residual"].get<double>(), 1e-14);
    EXPECT_EQ(j["pairs"], s["pairs"]);
    EXPECT_NEAR(j["form_factor_checks"]["max_row_sum"].get<double>(),
                s["form_factor_checks"]["max_row_sum"].get<double>(), 1e-15);
    EXPECT_NEAR(j["energy_w"]["relative_imbalance"].get<double>(), s["energy_w"]["relative_imbalance"].get<double>(),
                1e-12);
    if (ranks > 1) {
      const std::vector<int> rows = j["ranks"]["rows_per_rank"];
      EXPECT_EQ(std::accumulate(rows.begin(), rows.end(), 0), s["patches"].get<int>());
      EXPECT_EQ(j["form_factor_checks"]["reciprocity_error"], -1.0);  // not measured on ranks
    }
  }
  fs::remove_all(dir);
}

}  // namespace

// The rows split over the ranks, block Gauss–Seidel between them, the vertex gather split by point.
TEST(MpiSolve, TheSameRadiosityOnAnyNumberOfRanks) {
  expect_the_same_solve_on_ranks("distributed_mpi_solve", "", "gauss-seidel");
}

#if PHOTOMETRIA_HAVE_PETSC
// GMRES through PETSc on the ranks' rows (distributed/distributed_gmres.h) against this program's
// own GMRES in one process.
TEST(MpiSolve, GmresThroughPetscGivesTheSameRadiosityOnAnyNumberOfRanks) {
  expect_the_same_solve_on_ranks("distributed_mpi_gmres", "--solver gmres", "gmres");
}

// PETSc is a module beside the executable (distributed/petsc/petsc_gmres_module.h): a copy of the
// executable without it still runs everything else, and refuses GMRES on ranks in one line that
// says why.
TEST(MpiSolve, GmresWithoutThePetscModuleIsRefusedInOneLine) {
  const fs::path dir = test_scratch::fresh_dir("distributed_mpi_no_module");
  const fs::path alone = dir / "photometria";
  fs::copy_file(PHOTOMETRIA_BINARY, alone);
  const std::string cornell = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj";
  const auto run = [&](const std::string& solver) {
    return run_ranks(2, "solve " + cornell + " --quiet --solver " + solver + " -o " + (dir / "x.vtu").string(),
                     (dir / "err").string(), alone.string());
  };
  const cli_test::CliRun gmres = run("gmres");
  EXPECT_EQ(gmres.exit_code, 1) << gmres.err;
  EXPECT_NE(gmres.err.find("cannot load the PETSc module"), std::string::npos) << gmres.err;
  EXPECT_NE(gmres.err.find("libphotometria_petsc.so"), std::string::npos) << gmres.err;
  EXPECT_EQ(lines(gmres.err), 1) << gmres.err;
  const cli_test::CliRun gauss_seidel = run("gauss-seidel");
  EXPECT_EQ(gauss_seidel.exit_code, 0) << gauss_seidel.err;
  EXPECT_TRUE(fs::exists(dir / "x.vtu"));
  fs::remove_all(dir);
}
#endif

TEST(MpiSolve, WhatRunsAsOneProcessIsRefusedOnRanksInOneLine) {
  const fs::path dir = test_scratch::fresh_dir("distributed_mpi_solve_refused");
  const auto file = [&](const std::string& name) { return (dir / name).string(); };
  const std::string cornell = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj";
  const cli_test::CliRun sor =
      run_ranks(2, "solve " + cornell + " --quiet" + " --solver sor -o " + file("x.vtu"), file("err"));
  EXPECT_EQ(sor.exit_code, 1) << sor.err;
  EXPECT_NE(sor.err.find("--solver sor runs as one process"), std::string::npos) << sor.err;
  EXPECT_EQ(lines(sor.err), 1) << sor.err;
  const cli_test::CliRun hierarchy =
      run_ranks(2, "solve " + cornell + " --quiet" + " --method hierarchical -o " + file("x.vtu"), file("err"));
  EXPECT_EQ(hierarchy.exit_code, 1) << hierarchy.err;
  EXPECT_NE(hierarchy.err.find("--method hierarchical runs as one process"), std::string::npos) << hierarchy.err;
  const cli_test::CliRun memory =
      run_ranks(2, "solve " + cornell + " --quiet" + " --max-memory 1M -o " + file("x.vtu"), file("err"));
  EXPECT_EQ(memory.exit_code, 1) << memory.err;
  EXPECT_NE(memory.err.find("this rank needs"), std::string::npos) << memory.err;
  EXPECT_EQ(lines(memory.err), 1) << memory.err;
  const cli_test::CliRun unwritable =
      run_ranks(2, "solve " + cornell + " --quiet" + " -o /nonexistent-folder/x.vtu", file("err"));
  EXPECT_EQ(unwritable.exit_code, 2) << unwritable.err;
  EXPECT_EQ(lines(unwritable.err), 1) << unwritable.err;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().filename() != "err") ADD_FAILURE() << "left behind: " << entry.path();
  fs::remove_all(dir);
}

#endif
