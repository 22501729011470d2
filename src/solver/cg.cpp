#include "solver/cg.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "solver/gmres.h"

namespace photometria {
namespace {

// y = F x and yt = Fᵀ z in one pass over F (rows split over threads, Fᵀ z summed per thread).
void multiply_and_transpose(const FormFactors& F, const Eigen::VectorXd& x, const Eigen::VectorXd& z,
                            Eigen::VectorXd& y, Eigen::VectorXd& yt) {
  const int n = static_cast<int>(F.rows());
  y.resize(n);
  std::vector<Eigen::VectorXd> part(omp_get_max_threads(), Eigen::VectorXd::Zero(n));
#pragma omp parallel
  {
    Eigen::VectorXd& mine = part[omp_get_thread_num()];
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      y[i] = F.row_dot(i, x);
      if (z[i] != 0.0) F.add_row_to(i, z[i], mine);
    }
  }
  yt = part[0];
  for (size_t t = 1; t < part.size(); ++t) yt += part[t];
}

}  // namespace

double reciprocity_error(const FormFactors& F, const Eigen::VectorXd& A) {
  const int n = static_cast<int>(F.rows());
  constexpr int kBlock = 64;
  const int blocks = (n + kBlock - 1) / kBlock;
  double diff2 = 0.0, norm2 = 0.0;
  // Tiles (I, J) with J >= I, so each pair {S_ij, S_ji} is read once.
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : diff2, norm2)
  for (int bi = 0; bi < blocks; ++bi) {
    for (int bj = bi; bj < blocks; ++bj) {
      const int i1 = std::min(n, (bi + 1) * kBlock), j1 = std::min(n, (bj + 1) * kBlock);
      for (int i = bi * kBlock; i < i1; ++i)
        for (int j = (bi == bj ? i : bj * kBlock); j < j1; ++j) {
          const double sij = A[i] * F(i, j), sji = A[j] * F(j, i);  // S = diag(A) F
          if (i == j) {
            norm2 += sij * sij;
          } else {
            diff2 += 2.0 * (sij - sji) * (sij - sji);  // ‖S − Sᵀ‖_F² = 2 Σ_{i<j} (S_ij − S_ji)²
            norm2 += sij * sij + sji * sji;
          }
        }
    }
  }
  return norm2 > 0 ? std::sqrt(diff2 / norm2) : 0.0;
}

ChannelResult cg_channel(const ChannelProblem& p, const Eigen::VectorXd& A, const SolverOptions& opt,
                         Eigen::VectorXd& B) {
  const int n = static_cast<int>(p.E.size());
  const FormFactors& F = p.F;
  // Row weights w = A/ρ on patches with ρ > 0, 0 on the others (fixed at B = E; cg.h).
  Eigen::VectorXd w = Eigen::VectorXd::Zero(n), diag = Eigen::VectorXd::Ones(n);
  for (int i = 0; i < n; ++i)
    if (p.rho[i] > 0.0) {
      w[i] = A[i] / p.rho[i];
      diag[i] = w[i] - A[i] * F(i, i);  // diagonal of M_s = diag(A/ρ) − (S + Sᵀ)/2
    }
  B = p.E;
  Eigen::VectorXd r = residual_vector(p, B);  // true residual of K B = b; zero on ρ = 0 patches
  int matvecs = 1;
  double rel = relative_norm(r, B);
  std::ostringstream detail;
  int cycles = 0;
  Eigen::VectorXd rc, z, q, Fp, FtAp, Kp, dir(n);
  while (rel > opt.tolerance && matvecs < opt.max_iterations) {
    // One cycle: CG on M_s δ = w∘r (the scaled true residual), B += δ as it goes.
    ++cycles;
    const double cycle_start = rel;
    rc = w.cwiseProduct(r);
    z = rc.cwiseQuotient(diag);
    dir = z;
    double rz = rc.dot(z);
    bool indefinite = false;
    while (matvecs < opt.max_iterations) {
      multiply_and_transpose(F, dir, A.cwiseProduct(dir), Fp, FtAp);
      ++matvecs;
      // q = M_s p on the ρ > 0 patches (w = 0 masks the others; p is 0 there)
      q = w.cwiseProduct(dir) - 0.5 * (A.cwiseProduct(Fp) + FtAp);
      for (int i = 0; i < n; ++i)
        if (w[i] == 0.0) q[i] = 0.0;
      Kp = dir - p.rho.cwiseProduct(Fp);  // K p, for the true residual
      const double pq = dir.dot(q);
      if (!(pq > 0.0)) {
        indefinite = true;
        break;
      }
      // PCG step (Saad 2003, Algorithm 9.1)
      const double alpha = rz / pq;
      B += alpha * dir;
      rc -= alpha * q;
      r -= alpha * Kp;
      rel = relative_norm(r, B);
      if (rel <= opt.tolerance) {
        r = residual_vector(p, B);  // confirm on the true F (removes any drift of the update)
        ++matvecs;
        rel = relative_norm(r, B);
        break;
      }
      // The true residual no longer follows CG's: the asymmetric part of S dominates; refine.
      if (w.cwiseProduct(r).norm() > 2.0 * rc.norm()) {
        r = residual_vector(p, B);
        ++matvecs;
        rel = relative_norm(r, B);
        break;
      }
      z = rc.cwiseQuotient(diag);
      const double rz_next = rc.dot(z);
      dir = z + (rz_next / rz) * dir;
      rz = rz_next;
    }
    if (rel <= opt.tolerance) break;
    if (indefinite || rel > 0.5 * cycle_start) {
      detail << "cg: " << (indefinite ? "symmetric part not positive definite" : "refinement stalled") << " after "
             << matvecs << " products (relative residual " << rel << "); continued with gmres";
      ChannelResult g = gmres_channel(p, opt, B, matvecs);
      g.fell_back = true;
      g.detail = detail.str();
      return g;
    }
  }
  if (cycles > 1) detail << "cg: " << cycles << " refinement cycles (F not exactly reciprocal)";
  return {matvecs, rel, rel <= opt.tolerance, false, detail.str()};
}

}  // namespace photometria
