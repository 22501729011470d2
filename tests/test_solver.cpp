#include <gtest/gtest.h>

#include "formfactors/formfactors.h"
#include "scene_builders.h"
#include "solver/gauss_seidel.h"
#include "util/error.h"

using namespace photometria;

namespace {
FormFactorMatrix furnace_matrix(const PatchMesh& mesh) {
  FillStats stats;
  return fill_form_factors(mesh, FillOptions{}, stats).to_dense();
}
}  // namespace

// White furnace: closed room, uniform E and ρ: B = E / (1 − ρ) everywhere.
TEST(GaussSeidel, WhiteFurnaceMatchesTheClosedForm) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.25, 0.0});
  const FormFactorMatrix F = furnace_matrix(mesh);
  const int n = mesh.size();
  for (double rho : {0.5, 0.9, 0.99}) {
    ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R = ChannelMatrix::Constant(n, 3, rho), B;
    const SolverReport rep = solve_radiosity(F, E, R, ChannelMatrix::Zero(n, 3), true, {1e-12, 100000}, B);
    EXPECT_TRUE(rep.converged);
    EXPECT_EQ(rep.channels_solved, 1);
    EXPECT_LE(rep.residual, 1e-12);
    for (int i = 0; i < n; ++i) EXPECT_NEAR(B(i, 0) * (1 - rho), 1.0, 1e-9) << "rho " << rho;
  }
}

TEST(GaussSeidel, ColouredChannelsAreSolvedSeparately) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.5, 0.0});
  const FormFactorMatrix F = furnace_matrix(mesh);
  const int n = mesh.size();
  ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R(n, 3), B;
  R.col(0).setConstant(0.2);
  R.col(1).setConstant(0.5);
  R.col(2).setConstant(0.8);
  const SolverReport rep = solve_radiosity(F, E, R, ChannelMatrix::Zero(n, 3), false, {1e-12, 10000}, B);
  EXPECT_EQ(rep.channels_solved, 3);
  EXPECT_NEAR(B(0, 0), 1.25, 1e-9);
  EXPECT_NEAR(B(0, 1), 2.0, 1e-9);
  EXPECT_NEAR(B(0, 2), 5.0, 1e-9);
}

TEST(GaussSeidel, RefusesReflectanceOfOneAndNegativeEmission) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {});
  const FormFactorMatrix F = furnace_matrix(mesh);
  ChannelMatrix E = ChannelMatrix::Constant(6, 3, 1.0), R = ChannelMatrix::Constant(6, 3, 0.5), B;
  R(3, 1) = 1.0;
  try {
    solve_radiosity(F, E, R, ChannelMatrix::Zero(6, 3), false, {}, B);
    FAIL() << "ρ = 1 accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("reflectance 1"), std::string::npos) << e.what();
  }
  R(3, 1) = 0.5;
  E(2, 0) = -1;
  EXPECT_THROW(solve_radiosity(F, E, R, ChannelMatrix::Zero(6, 3), false, {}, B), Error);
}

TEST(GaussSeidel, ReportsNonConvergenceAtTheCap) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.5, 0.0});
  const FormFactorMatrix F = furnace_matrix(mesh);
  const int n = mesh.size();
  ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R = ChannelMatrix::Constant(n, 3, 0.99), B;
  const SolverReport rep = solve_radiosity(F, E, R, ChannelMatrix::Zero(n, 3), true, {1e-12, 5, SolverMethod::GaussSeidel}, B);
  EXPECT_FALSE(rep.converged);
  EXPECT_EQ(rep.iterations, 5);
  EXPECT_GT(rep.residual, 1e-12);
}
