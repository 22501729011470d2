#include "solver/solver.h"

#include <chrono>
#include <cmath>
#include <sstream>

#include "solver/cg.h"
#include "solver/direct.h"
#include "solver/gauss_seidel.h"
#include "solver/gmres.h"
#include "solver/sor.h"
#include "util/error.h"

namespace photometria {
namespace {

void check_inputs(const ChannelMatrix& E, const ChannelMatrix& rho) {
  for (int i = 0; i < E.rows(); ++i)
    for (int c = 0; c < 3; ++c) {
      if (!(rho(i, c) >= 0.0 && rho(i, c) < 1.0)) {
        std::ostringstream s;
        s << "patch " << i << ": reflectance " << rho(i, c) << " (channel " << c
          << ") must be in [0, 1) or the solution does not converge";
        throw_bad_input(s.str());
      }
      if (!(E(i, c) >= 0.0) || !std::isfinite(E(i, c))) {
        std::ostringstream s;
        s << "patch " << i << ": emission " << E(i, c) << " (channel " << c << ") must be finite and >= 0";
        throw_bad_input(s.str());
      }
    }
}

}  // namespace

const char* method_name(SolverMethod m) {
  switch (m) {
    case SolverMethod::Auto: return "auto";
    case SolverMethod::GaussSeidel: return "gauss-seidel";
    case SolverMethod::Sor: return "sor";
    case SolverMethod::Cg: return "cg";
    case SolverMethod::Gmres: return "gmres";
    case SolverMethod::Direct: return "direct";
  }
  return "?";
}

SolverMethod parse_method(const std::string& name) {
  for (SolverMethod m : {SolverMethod::Auto, SolverMethod::GaussSeidel, SolverMethod::Sor, SolverMethod::Cg,
                         SolverMethod::Gmres, SolverMethod::Direct})
    if (name == method_name(m)) return m;
  throw_bad_input("solver '" + name + "': expected auto, gauss-seidel, sor, cg, gmres or direct");
}

SolverMethod choose_method(double max_reflectance, int patches, bool areas_known) {
  // Thresholds explained in solver.h and measured in docs/performance.md "Solvers".
  if (max_reflectance <= 0.9) return SolverMethod::GaussSeidel;
  if (patches <= 64) return SolverMethod::Direct;
  (void)areas_known;  // cg is not chosen: with quadrature F (not reciprocal) gmres was faster
  return SolverMethod::Gmres;
}

SolverReport solve_radiosity(const FormFactors& F, const ChannelMatrix& E, const ChannelMatrix& rho,
                             const ChannelMatrix& H, bool grey, const SolverOptions& options, ChannelMatrix& B) {
  const auto start = std::chrono::steady_clock::now();
  check_inputs(E, rho);
  const int n = static_cast<int>(E.rows());
  const bool areas_known = options.areas.size() > 0;
  if (areas_known) {
    if (options.areas.size() != n) {
      std::ostringstream s;
      s << "solver: " << options.areas.size() << " patch areas given for " << n << " patches";
      throw_bad_input(s.str());
    }
    for (int i = 0; i < n; ++i)
      if (!(options.areas[i] > 0.0) || !std::isfinite(options.areas[i])) {
        std::ostringstream s;
        s << "solver: patch " << i << " has area " << options.areas[i] << "; cg needs areas > 0";
        throw_bad_input(s.str());
      }
  }
  SolverReport report;
  // One channel only when the inputs really are grey (a coloured light over grey materials is not).
  const auto same_channels = [](const ChannelMatrix& m) { return m.col(1) == m.col(0) && m.col(2) == m.col(0); };
  report.channels_solved = grey && same_channels(E) && same_channels(rho) && same_channels(H) ? 1 : 3;
  report.method = options.method == SolverMethod::Auto
                      ? choose_method(n > 0 ? rho.leftCols(report.channels_solved).maxCoeff() : 0.0, n, areas_known)
                      : options.method;
  if (report.method == SolverMethod::Cg && !areas_known)
    throw_bad_input("solver cg: the symmetric formulation needs the patch areas (SolverOptions::areas)");
  if (report.method == SolverMethod::Direct && n > options.direct_max_patches) {
    std::ostringstream s;
    s << "solver direct: " << n << " patches > limit " << options.direct_max_patches << " (a dense LU needs "
      << 8.0 * n * n / 1e9 << " GB and ~" << 2.0 * n * n * n / 3e9 << " Gflop)";
    throw_bad_input(s.str());
  }
  if (report.method == SolverMethod::Sor) report.omega = options.omega > 0 ? options.omega : young_omega(F, rho.col(0));
  if (report.method == SolverMethod::Sor && !(report.omega > 0 && report.omega < 2)) {
    std::ostringstream s;
    s << "solver sor: relaxation factor " << report.omega << " must be in (0, 2)";
    throw_bad_input(s.str());
  }
  if (report.method == SolverMethod::Cg) report.reciprocity_error = reciprocity_error(F, options.areas);

  B.resize(n, 3);
  report.converged = true;
  bool fell_back = false;
  for (int c = 0; c < report.channels_solved; ++c) {
    const ChannelProblem p{F, E.col(c), rho.col(c), H.col(c)};
    Eigen::VectorXd b;
    ChannelResult r;
    switch (report.method) {
      case SolverMethod::Sor: {
        // ω from this channel's reflectances unless the user fixed it.
        const double omega = options.omega > 0 ? options.omega : (c == 0 ? report.omega : young_omega(F, p.rho));
        report.omega = std::max(report.omega, omega);
        r = sor_channel(p, omega, options, b);
        break;
      }
      case SolverMethod::Cg: r = cg_channel(p, options.areas, options, b); break;
      case SolverMethod::Gmres: r = gmres_channel(p, options, b = p.E); break;
      case SolverMethod::Direct: r = direct_channel(p, options, b); break;
      default: r = gauss_seidel_channel(p, options, b); break;
    }
    B.col(c) = b;
    fell_back = fell_back || r.fell_back;
    if (!r.detail.empty()) report.detail += (report.detail.empty() ? "" : "; ") + r.detail;
    report.iterations = std::max(report.iterations, r.iterations);
    report.residual = std::max(report.residual, r.residual);
    report.converged = report.converged && r.converged;
  }
  if (fell_back) report.method = SolverMethod::Gmres;
  for (int c = report.channels_solved; c < 3; ++c) B.col(c) = B.col(0);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace photometria
