#include "solver/gmres.h"

#include <cmath>
#include <vector>

namespace photometria {

ChannelResult gmres_channel(const ChannelProblem& p, const SolverOptions& opt, Eigen::VectorXd& B, int used,
                            int restart) {
  const int n = static_cast<int>(p.E.size());
  const int m = std::max(1, restart);
  int matvecs = used;
  Eigen::VectorXd r = residual_vector(p, B);  // r = b − K B  (solver.h)
  ++matvecs;
  double rel = relative_norm(r, B);
  Eigen::MatrixXd V(n, m + 1), H = Eigen::MatrixXd::Zero(m + 1, m);
  Eigen::VectorXd g(m + 1), cs(m), sn(m), w, Fw;
  while (rel > opt.tolerance && matvecs < opt.max_iterations) {
    const double beta = r.norm();
    const double target = 0.5 * opt.tolerance * B.norm();  // ‖B‖ only grows in these solves: conservative
    V.col(0) = r / beta;
    g.setZero();
    g[0] = beta;
    H.setZero();
    int k = 0;
    for (; k < m && matvecs < opt.max_iterations;) {
      // Arnoldi step (Saad 2003, Algorithm 6.2, modified Gram–Schmidt): w = K v_k
      multiply(p.F, V.col(k), Fw);
      ++matvecs;
      w = V.col(k) - p.rho.cwiseProduct(Fw);
      for (int j = 0; j <= k; ++j) {
        H(j, k) = V.col(j).dot(w);
        w -= H(j, k) * V.col(j);
      }
      H(k + 1, k) = w.norm();
      const bool breakdown = !(H(k + 1, k) > 0);  // K-invariant subspace found: the solution is in it
      if (!breakdown) V.col(k + 1) = w / H(k + 1, k);
      // Least squares by Givens rotations (Saad 2003, §6.5.3)
      for (int j = 0; j < k; ++j) {
        const double t = cs[j] * H(j, k) + sn[j] * H(j + 1, k);
        H(j + 1, k) = -sn[j] * H(j, k) + cs[j] * H(j + 1, k);
        H(j, k) = t;
      }
      const double d = std::hypot(H(k, k), H(k + 1, k));
      cs[k] = H(k, k) / d;
      sn[k] = H(k + 1, k) / d;
      H(k, k) = d;
      H(k + 1, k) = 0;
      g[k + 1] = -sn[k] * g[k];
      g[k] = cs[k] * g[k];
      ++k;
      if (std::abs(g[k]) <= target || breakdown) break;  // |g_{k}| = ‖r_k‖₂
    }
    // y = R⁻¹ g, B += V y
    const Eigen::VectorXd y = H.topLeftCorner(k, k).triangularView<Eigen::Upper>().solve(g.head(k));
    B += V.leftCols(k) * y;
    r = residual_vector(p, B);
    ++matvecs;
    rel = relative_norm(r, B);
  }
  return {matvecs, rel, rel <= opt.tolerance, false, ""};
}

}  // namespace photometria
