// Hottel's total exchange factors (script-F, viewfactors.h exchange_factors; View3D's C emit=1):
// two-surface enclosures against their closed form, unit emissivities giving the view factors
// back, reciprocity and row sums on a meshed cube, the result against View3D's own formulation
// (its IntFac: symmetric system with the areas folded in, solved here by a different
// factorisation), perfect reflectors, and refusals.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <string>
#include <vector>

#include "scene_builders.h"
#include "util/error.h"
#include "viewfactors/viewfactors.h"

using namespace photometria;

namespace {

// Two-surface enclosure (surface 1 convex, F11 = 0, F12 = 1): the net exchange of Modest,
// "Radiative Heat Transfer", 3rd ed., 2013, ch. 5 (the two-surface enclosure of the net
// radiation method), q12 = σ(T1⁴ − T2⁴) A1 / (1/ε1 + (A1/A2)(1/ε2 − 1)), as an exchange factor,
//   sF12 = 1 / (1/ε1 + (A1/A2) (1/ε2 − 1)),
// the rest from reciprocity (A1 sF12 = A2 sF21) and row sums (Σ_j sF_ij = ε_i).
struct TwoSurface {
  double a1, a2, e1, e2;
};

void check_two_surface(const TwoSurface& c) {
  SCOPED_TRACE("A1 " + std::to_string(c.a1) + " A2 " + std::to_string(c.a2) + " e1 " + std::to_string(c.e1) + " e2 " +
               std::to_string(c.e2));
  const double f21 = c.a1 / c.a2;
  ViewFactorMatrix F(2, 2);
  F << 0.0, 1.0, f21, 1.0 - f21;
  const ViewFactorMatrix S = exchange_factors(F, {c.e1, c.e2});
  const double s12 = 1.0 / (1.0 / c.e1 + c.a1 / c.a2 * (1.0 / c.e2 - 1.0));
  const double s21 = c.a1 / c.a2 * s12;
  EXPECT_NEAR(S(0, 1), s12, 1e-14);
  EXPECT_NEAR(S(1, 0), s21, 1e-14);
  EXPECT_NEAR(S(0, 0), c.e1 - s12, 1e-14);
  EXPECT_NEAR(S(1, 1), c.e2 - s21, 1e-14);
}

// View3D's formulation (IntFac; Hottel & Sarofim 1967, pp. 84-86), written out here from its
// equations: with M = A·F − diag(A/ρ) (symmetric for reciprocal F) and a_i = A_i ε_i / ρ_i, the
// radiosities J of a unit blackbody emission of surface k solve M J = −a_k e_k, and
//   A_k sF_km = a_m J_m (m ≠ k),   A_k sF_kk = a_k (J_k − ε_k).
// Needs 0 < ε < 1. Solved by full-pivoting LU (the code under test uses partial pivoting on a
// different matrix).
ViewFactorMatrix view3d_intfac(const ViewFactorMatrix& F, const std::vector<double>& A,
                               const std::vector<double>& eps) {
  const int n = static_cast<int>(F.rows());
  Eigen::MatrixXd M(n, n);
  Eigen::VectorXd a(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) M(i, j) = A[size_t(i)] * F(i, j);
    M(i, i) -= A[size_t(i)] / (1.0 - eps[size_t(i)]);
    a[i] = A[size_t(i)] * eps[size_t(i)] / (1.0 - eps[size_t(i)]);
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(M);
  ViewFactorMatrix S(n, n);
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd b = Eigen::VectorXd::Zero(n);
    b[k] = -a[k];
    const Eigen::VectorXd J = lu.solve(b);
    for (int m = 0; m < n; ++m) S(k, m) = (a[m] * J[m] - (m == k ? a[k] * eps[size_t(k)] : 0.0)) / A[size_t(k)];
  }
  return S;
}

// The unit cube at patch level (24 patches of 0.5 × 0.5), enforced to exact reciprocity and
// closure, with emissivities 0.05 .. 0.97 varying from patch to patch.
struct Cube {
  ViewFactorMatrix F;
  std::vector<double> areas, eps;
};

Cube meshed_cube() {
  ViewFactorOptions o;
  o.patching.max_edge = 0.5 + 1e-9;
  const Scene s = builders::unit_cube();
  const PatchViewFactors r = compute_view_factors(s, o);
  const Aggregation agg = make_aggregation(s, r.mesh, AggregateLevel::Patch);
  Cube c;
  c.F = aggregate(r.F, r.mesh, agg);
  c.areas = agg.areas;
  enforce(c.F, c.areas, Enforcement::Both);
  for (int i = 0; i < c.F.rows(); ++i) c.eps.push_back(0.05 + 0.92 * (0.5 + 0.5 * std::sin(1.0 + 2.3 * i)));
  return c;
}

std::string error_of(const ViewFactorMatrix& F, const std::vector<double>& eps) {
  try {
    exchange_factors(F, eps);
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    return e.what();
  }
  return "";
}

}  // namespace

TEST(ExchangeFactors, TwoSurfaceEnclosuresMatchTheClosedForm) {
  check_two_surface({1.0, 4.0, 0.3, 0.6});   // concentric spheres, radii 1 and 2
  check_two_surface({2.0, 8.0, 0.4, 0.7});   // the box of tests/data/view3d_two_surface_emit.vs3
  check_two_surface({1.0, 1.0, 0.8, 0.05});  // infinite parallel plates: 1/(1/ε1 + 1/ε2 − 1)
  check_two_surface({1.0, 1e3, 0.5, 0.01});  // small body in a large enclosure: sF12 -> ε1
  check_two_surface({3.0, 5.0, 1.0, 0.25});  // a black surface (ρ1 = 0)
  // The parallel plates' textbook form, written out.
  ViewFactorMatrix F(2, 2);
  F << 0.0, 1.0, 1.0, 0.0;
  EXPECT_NEAR(exchange_factors(F, {0.8, 0.5})(0, 1), 1.0 / (1.0 / 0.8 + 1.0 / 0.5 - 1.0), 1e-15);
}

TEST(ExchangeFactors, UnitEmissivitiesGiveTheViewFactorsBack) {
  const Cube c = meshed_cube();
  const ViewFactorMatrix S = exchange_factors(c.F, std::vector<double>(c.areas.size(), 1.0));
  EXPECT_LE((S - c.F).cwiseAbs().maxCoeff(), 1e-15);
  // Also for an open geometry (rows summing to less than 1): two facing unit squares 1 apart.
  ViewFactorMatrix P(2, 2);
  P << 0.0, 0.19982489569838738, 0.19982489569838738, 0.0;
  EXPECT_EQ(exchange_factors(P, {1.0, 1.0}), P);
}

TEST(ExchangeFactors, ReciprocalRowsSumToTheEmissivitiesAndAgreeWithView3dsFormulation) {
  const Cube c = meshed_cube();
  const int n = static_cast<int>(c.F.rows());
  ASSERT_EQ(n, 24);
  const ViewFactorMatrix S = exchange_factors(c.F, c.eps);
  double reciprocity = 0.0, rows = 0.0;
  for (int i = 0; i < n; ++i) {
    rows = std::max(rows, std::abs(S.row(i).sum() - c.eps[size_t(i)]));
    for (int j = 0; j < n; ++j)
      reciprocity = std::max(reciprocity, std::abs(c.areas[size_t(i)] * S(i, j) - c.areas[size_t(j)] * S(j, i)));
  }
  EXPECT_LE(reciprocity, 1e-15);
  EXPECT_LE(rows, 1e-14);
  EXPECT_GE(S.minCoeff(), 0.0);
  // The diagonal is not zero: a flat patch sees none of itself, but gets its own emission back
  // after reflections.
  for (int i = 0; i < n; ++i) EXPECT_GT(S(i, i), 0.0) << i;
  EXPECT_LE((S - view3d_intfac(c.F, c.areas, c.eps)).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(ExchangeFactors, ZeroEmissivityIsAPerfectReflector) {
  // The cube with patch 3 a perfect reflector: its row and column are zero, the other rows still
  // sum to their emissivities (what patch 3 receives it reflects to the others).
  Cube c = meshed_cube();
  c.eps[3] = 0.0;
  const ViewFactorMatrix S = exchange_factors(c.F, c.eps);
  EXPECT_EQ(S.row(3).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(S.col(3).cwiseAbs().maxCoeff(), 0.0);
  for (int i = 0; i < S.rows(); ++i) {
    if (i != 3) { EXPECT_NEAR(S.row(i).sum(), c.eps[size_t(i)], 1e-14) << i; }
  }
  // Two-surface check of the same thing: the reflector passes everything on.
  ViewFactorMatrix F(2, 2);
  F << 0.0, 1.0, 0.25, 0.75;
  const ViewFactorMatrix T = exchange_factors(F, {0.6, 0.0});
  EXPECT_NEAR(T(0, 0), 0.6, 1e-15);
  EXPECT_EQ(T(0, 1), 0.0);
}

TEST(ExchangeFactors, SingularSystemsAndBadEmissivitiesAreRefused) {
  ViewFactorMatrix F(2, 2);
  F << 0.0, 1.0, 0.25, 0.75;
  // Every surface a perfect reflector in a closed enclosure: nothing is ever absorbed.
  EXPECT_NE(error_of(F, {0.0, 0.0}).find("singular"), std::string::npos);
  // The enforced cube likewise (rows summing to 1 within 1e-14).
  const Cube c = meshed_cube();
  EXPECT_NE(error_of(c.F, std::vector<double>(c.areas.size(), 0.0)).find("singular"), std::string::npos);
  EXPECT_NE(error_of(F, {0.5, 1.5}).find("emissivity 1.5 of surface 2 is outside [0, 1]"), std::string::npos);
  EXPECT_NE(error_of(F, {0.5, std::nan("")}).find("of surface 2 is outside [0, 1]"), std::string::npos);
  EXPECT_NE(error_of(F, {0.5}).find("1 emissivities for 2 x 2 view factors"), std::string::npos);
}
