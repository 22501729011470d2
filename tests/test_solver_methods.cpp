// Every solver method (solver.h) against closed forms and against each other.
#include <gtest/gtest.h>

#include <cmath>

#include "formfactors/formfactors.h"
#include "refs.h"
#include "scene_builders.h"
#include "solver/cg.h"
#include "solver/solver.h"
#include "solver/sor.h"
#include "util/error.h"

using namespace photometria;

namespace {

const SolverMethod kAll[] = {SolverMethod::GaussSeidel, SolverMethod::Sor, SolverMethod::Cg, SolverMethod::Gmres,
                             SolverMethod::Direct};

struct Room {
  PatchMesh mesh;
  FormFactorMatrix F;
  Eigen::VectorXd areas;
};

Room room(double max_edge) {
  Room r;
  r.mesh = subdivide(builders::unit_cube(), {max_edge, 0.0});
  FillStats stats;
  r.F = fill_form_factors(r.mesh, FillOptions{}, stats).to_dense();
  r.areas.resize(r.mesh.size());
  for (int i = 0; i < r.mesh.size(); ++i) r.areas[i] = r.mesh.patches[i].area;
  return r;
}

SolverOptions options(SolverMethod m, const Eigen::VectorXd& areas, double tol = 1e-12) {
  SolverOptions o;
  o.tolerance = tol;
  o.method = m;
  o.areas = areas;
  return o;
}

double max_relative_difference(const ChannelMatrix& a, const ChannelMatrix& b) {
  return ((a - b).array().abs() / b.array().abs().max(1e-300)).maxCoeff();
}

}  // namespace

// White furnace (refs white_furnace_cube_rho*): B = E/(1 − ρ) whatever the meshing, for every method.
TEST(SolverMethods, WhiteFurnaceEveryMethodEveryRho) {
  const Room r = room(0.25);  // 4 × 4 per wall, N = 96
  const int n = r.mesh.size();
  for (double rho : {0.5, 0.9, 0.99, 0.999})
    for (SolverMethod m : kAll) {
      ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R = ChannelMatrix::Constant(n, 3, rho), B;
      const SolverReport rep = solve_radiosity(r.F, E, R, ChannelMatrix::Zero(n, 3), true, options(m, r.areas), B);
      EXPECT_TRUE(rep.converged) << method_name(m) << " rho " << rho;
      EXPECT_EQ(rep.method, m) << method_name(m) << " rho " << rho << ": " << rep.detail;
      EXPECT_LE(rep.residual, 1e-12);
      EXPECT_GE(rep.seconds, 0.0);
      for (int i = 0; i < n; ++i) EXPECT_NEAR(B(i, 0) * (1 - rho), 1.0, 1e-9) << method_name(m) << " rho " << rho;
    }
}

// Six patches, exact analytic factors (Howell C-11, C-14 as given in the reference case), only the
// floor emitting: every method against the reference values and against the direct solve.
TEST(SolverMethods, CubeFloorEmittingSixPatchesMatchesReference) {
  const auto& c = refs::find("cube_floor_emitting_rho0.5");
  const double fo = c["geometry"]["form_factors"]["F_opposite (C-11, a=b=c=1)"].get<double>();
  const double fa = c["geometry"]["form_factors"]["F_adjacent (C-14, l=w=h=1)"].get<double>();
  FormFactorMatrix F = FormFactorMatrix::Constant(6, 6, fa);
  for (int i = 0; i < 6; ++i) F(i, i) = 0.0;
  for (auto [i, j] : {std::pair{0, 1}, {2, 4}, {3, 5}}) F(i, j) = F(j, i) = fo;  // opposite walls
  ChannelMatrix E = ChannelMatrix::Zero(6, 3), R = ChannelMatrix::Constant(6, 3, 0.5), Bd;
  E.row(0).setConstant(1.0);
  const Eigen::VectorXd areas = Eigen::VectorXd::Ones(6);
  solve_radiosity(F, E, R, ChannelMatrix::Zero(6, 3), true, options(SolverMethod::Direct, areas), Bd);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(Bd(i, 0), double(refs::number(c["value"][i])), 1e-12) << i;
  for (SolverMethod m : kAll) {
    ChannelMatrix B;
    const SolverReport rep = solve_radiosity(F, E, R, ChannelMatrix::Zero(6, 3), true, options(m, areas), B);
    EXPECT_TRUE(rep.converged) << method_name(m);
    EXPECT_EQ(rep.method, m) << method_name(m) << ": " << rep.detail;
    EXPECT_LE(max_relative_difference(B, Bd), 1e-11) << method_name(m);
    if (m == SolverMethod::Cg) {
      EXPECT_NEAR(rep.reciprocity_error, 0.0, 1e-15);  // exact factors are reciprocal
    }
  }
}

// A coloured, non-grey, non-uniform scene: floor-only emission, reflectance varying by patch and
// channel, channel 0 with black (ρ = 0) walls, channel 2 near 1. All methods agree with direct.
TEST(SolverMethods, MethodsAgreeOnAColouredScene) {
  const Room r = room(0.25);
  const int n = r.mesh.size();
  ChannelMatrix E = ChannelMatrix::Zero(n, 3), R(n, 3), H = ChannelMatrix::Zero(n, 3), Bd;
  for (int i = 0; i < n; ++i) {
    const Patch& p = r.mesh.patches[i];
    if (p.face == 0) E.row(i) << 1.0, 2.0, 0.5;
    if (p.face == 1) H.row(i) << 0.3, 0.0, 0.1;  // some direct light on the ceiling
    const double t = 0.5 + 0.5 * std::sin(3.0 * p.centroid.x() + 2.0 * p.centroid.y() + p.centroid.z());
    R.row(i) << (p.face >= 2 ? 0.0 : 0.3 + 0.4 * t), 0.6 + 0.3 * t, 0.99 + 0.009 * t;
  }
  solve_radiosity(r.F, E, R, H, false, options(SolverMethod::Direct, r.areas), Bd);
  for (SolverMethod m : kAll) {
    ChannelMatrix B;
    const SolverReport rep = solve_radiosity(r.F, E, R, H, false, options(m, r.areas), B);
    EXPECT_EQ(rep.channels_solved, 3);
    EXPECT_TRUE(rep.converged) << method_name(m);
    EXPECT_LE(max_relative_difference(B, Bd), 1e-9) << method_name(m) << " " << rep.detail;
  }
  // Black patches keep exactly their emission in channel 0.
  ChannelMatrix B;
  solve_radiosity(r.F, E, R, H, false, options(SolverMethod::Cg, r.areas), B);
  for (int i = 0; i < n; ++i)
    if (R(i, 0) == 0.0) { EXPECT_EQ(B(i, 0), E(i, 0)); }
}

// Centroid-rule factors are not reciprocal: cg says how far off they are, and still solves the
// true system (refinement or fallback) — the answer matches the direct solve of the same F.
TEST(SolverMethods, CgMeasuresNonReciprocityAndStillSolvesTheTrueSystem) {
  const Room r = room(0.25);
  const int n = r.mesh.size();
  const double err = reciprocity_error(r.F, r.areas);
  EXPECT_GT(err, 1e-3);  // the centroid rule is far from reciprocal near shared edges
  EXPECT_LT(err, 0.5);
  // An exactly reciprocal F: S = (diag(A)F + (diag(A)F)ᵀ)/2, F' = diag(1/A) S.
  const Eigen::MatrixXd S = r.areas.asDiagonal() * r.F;
  const FormFactorMatrix Fr = r.areas.cwiseInverse().asDiagonal() * (0.5 * (S + S.transpose()));
  EXPECT_LT(reciprocity_error(Fr, r.areas), 1e-15);
  ChannelMatrix E = ChannelMatrix::Zero(n, 3), R = ChannelMatrix::Constant(n, 3, 0.999), Bd, B;
  for (int i = 0; i < n; ++i)
    if (r.mesh.patches[i].face == 0) E.row(i).setConstant(1.0);
  for (const FormFactorMatrix* F : {&r.F, &Fr}) {
    solve_radiosity(*F, E, R, ChannelMatrix::Zero(n, 3), true, options(SolverMethod::Direct, r.areas), Bd);
    const SolverReport rep =
        solve_radiosity(*F, E, R, ChannelMatrix::Zero(n, 3), true, options(SolverMethod::Cg, r.areas), B);
    EXPECT_TRUE(rep.converged);
    EXPECT_LE(rep.residual, 1e-12);
    EXPECT_LE(max_relative_difference(B, Bd), 1e-9) << rep.detail;
    if (F == &Fr) {
      EXPECT_EQ(rep.method, SolverMethod::Cg);
      EXPECT_EQ(rep.detail, "");  // reciprocal: plain CG, no refinement, no fallback
    }
  }
}

// Young's ω: for a closed room the Jacobi bound is exactly ρ (rows of F sum to 1).
TEST(SolverMethods, YoungOmegaForAClosedRoom) {
  const Room r = room(0.5);
  for (double rho : {0.5, 0.999}) {
    const Eigen::VectorXd R = Eigen::VectorXd::Constant(r.mesh.size(), rho);
    EXPECT_NEAR(young_omega(r.F, R), 2.0 / (1.0 + std::sqrt(1.0 - rho * rho)), 1e-9);
  }
  EXPECT_EQ(young_omega(r.F, Eigen::VectorXd::Zero(r.mesh.size())), 1.0);
}

// auto: the documented rule (solver.h), and what solve_radiosity reports it ran.
TEST(SolverMethods, AutoPicksTheDocumentedMethod) {
  EXPECT_EQ(choose_method(0.0, 10000, true), SolverMethod::GaussSeidel);
  EXPECT_EQ(choose_method(0.9, 10000, true), SolverMethod::GaussSeidel);
  EXPECT_EQ(choose_method(0.95, 64, true), SolverMethod::Direct);
  EXPECT_EQ(choose_method(0.95, 65, true), SolverMethod::Gmres);
  EXPECT_EQ(choose_method(0.999, 6000, false), SolverMethod::Gmres);
  const Room r = room(0.25);
  const int n = r.mesh.size();
  ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R = ChannelMatrix::Constant(n, 3, 0.5), B;
  R(7, 2) = 0.95;  // one channel of one patch makes the scene stiff
  EXPECT_EQ(
      solve_radiosity(r.F, E, R, ChannelMatrix::Zero(n, 3), false, options(SolverMethod::Auto, r.areas), B).method,
      SolverMethod::Gmres);
  R(7, 2) = 0.5;
  EXPECT_EQ(solve_radiosity(r.F, E, R, ChannelMatrix::Zero(n, 3), true, options(SolverMethod::Auto, r.areas), B).method,
            SolverMethod::GaussSeidel);
}

TEST(SolverMethods, RefusesReflectanceOfOneWhateverTheMethod) {
  const Room r = room(0.5);
  const int n = r.mesh.size();
  ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R = ChannelMatrix::Constant(n, 3, 0.5), B;
  for (double bad : {1.0, 1.5}) {
    R(3, 1) = bad;
    for (SolverMethod m : {SolverMethod::Auto, SolverMethod::GaussSeidel, SolverMethod::Sor, SolverMethod::Cg,
                           SolverMethod::Gmres, SolverMethod::Direct}) {
      try {
        solve_radiosity(r.F, E, R, ChannelMatrix::Zero(n, 3), false, options(m, r.areas), B);
        ADD_FAILURE() << method_name(m) << " accepted rho " << bad;
      } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::BadInput);
        EXPECT_NE(std::string(e.what()).find("reflectance"), std::string::npos) << e.what();
      }
    }
  }
}

TEST(SolverMethods, NamesAndMisuseAreReported) {
  for (SolverMethod m : {SolverMethod::Auto, SolverMethod::GaussSeidel, SolverMethod::Sor, SolverMethod::Cg,
                         SolverMethod::Gmres, SolverMethod::Direct})
    EXPECT_EQ(parse_method(method_name(m)), m);
  EXPECT_THROW(parse_method("jacobi"), Error);
  const Room r = room(0.5);
  const int n = r.mesh.size();
  ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R = ChannelMatrix::Constant(n, 3, 0.5), B;
  EXPECT_THROW(solve_radiosity(r.F, E, R, ChannelMatrix::Zero(n, 3), true, options(SolverMethod::Cg, {}), B), Error);
  SolverOptions o = options(SolverMethod::Direct, r.areas);
  o.direct_max_patches = n - 1;
  EXPECT_THROW(solve_radiosity(r.F, E, R, ChannelMatrix::Zero(n, 3), true, o, B), Error);
  o = options(SolverMethod::Sor, r.areas);
  o.omega = 2.0;
  EXPECT_THROW(solve_radiosity(r.F, E, R, ChannelMatrix::Zero(n, 3), true, o, B), Error);
}
