#include "validation/suite.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include <sys/wait.h>

#include "formfactors/formfactors.h"
#include "formfactors/pair_integration.h"
#include "formfactors/quadrature.h"
#include "hierarchical/hierarchical.h"
#include "io/atomic_file.h"
#include "kernels/distant.h"
#include "kernels/lambert.h"
#include "kernels/sphere.h"
#include "patching/patching.h"
#include "pipeline/direct_light.h"
#include "solver/gauss_seidel.h"
#include "util/error.h"
#include "validation/scenes.h"
#include "visibility/visibility.h"

namespace photometria::validation {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

Vec3 vec(const nlohmann::json& v) { return {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()}; }
Polygon polygon(const nlohmann::json& v) {
  Polygon p;
  for (const auto& x : v) p.push_back(vec(x));
  return p;
}
SolverOptions gauss_seidel_to(double tolerance, int max_iterations) {
  SolverOptions o;
  o.tolerance = tolerance;
  o.max_iterations = max_iterations;
  return o;
}

double number(const nlohmann::json& v) { return std::stod(v.get<std::string>()); }

const nlohmann::json& find_case(const nlohmann::json& refs, const std::string& id) {
  for (const auto& c : refs.at("cases"))
    if (c.at("id") == id) return c;
  throw_bad_input("reference file: no case '" + id + "'");
}

// Accumulates relative errors (absolute where the reference is 0) of one row.
struct ErrorStats {
  double max = 0.0, sum2 = 0.0;
  int n = 0;
  void add(double got, double want) {
    const double e = want != 0.0 ? std::abs((got - want) / want) : std::abs(got);
    max = std::max(max, e);
    sum2 += e * e;
    ++n;
  }
  void into(ValidationRow& r) const {
    r.max_rel_error = max;
    r.rms_rel_error = n ? std::sqrt(sum2 / n) : 0.0;
    r.cases = n;
  }
};

class Suite {
 public:
  Suite(const nlohmann::json& refs, const ValidationOptions& o) : refs_(refs), opt_(o) {}

  std::vector<ValidationRow> run() {
    warm_up();
    point_polygon();
    lights();
    occluded_point();
    occluded_patch();
    patch_patch();
    coaxial_disks();
    patch_patch_adaptive();
    cube_floor_emitting();
    white_furnace();
    furnace_solvers();
    hierarchical_furnace();
    sphere_cap();
    return rows_;
  }

 private:
  const nlohmann::json& refs_;
  const ValidationOptions& opt_;
  std::vector<ValidationRow> rows_;

  // Start the thread pool before the first timed row so it does not pay for it.
  void warm_up() {
    FillStats st;
    fill_form_factors(subdivide(unit_cube_scene(0.5, 1.0, -1), {0.5, 0.0}), FillOptions{}, st);
  }

  void emit(ValidationRow r) {
    if (opt_.on_row) opt_.on_row(r);
    rows_.push_back(std::move(r));
  }

  // Lambert's closed form against every point_polygon case (exact: one setting).
  void point_polygon() {
    ErrorStats err;
    const auto t0 = Clock::now();
    for (const auto& c : refs_.at("cases")) {
      if (c.at("kind") != "point_polygon") continue;
      const auto& g = c.at("geometry");
      const Receiver r{vec(g["receiver"]["point"]), vec(g["receiver"]["normal"]).normalized()};
      err.add(lambert_form_factor(r, polygon(g["polygon"])), number(c["value"]));
    }
    ValidationRow row{"point-to-polygon (Lambert)", "closed form", 0, 1, 0, 0, 0, since(t0)};
    err.into(row);
    emit(row);
  }

  // Sphere lights (Howell B-39/B-43, incl. the horizon-crossing branch) and distant-light cones.
  void lights() {
    ErrorStats err;
    const auto t0 = Clock::now();
    for (const auto& c : refs_.at("cases")) {
      const auto& g = c.at("geometry");
      if (c.at("kind") == "sphere_light") {
        const Receiver r{vec(g["receiver"]["point"]), vec(g["receiver"]["normal"]).normalized()};
        err.add(sphere_form_factor(r, vec(g["sphere"]["center"]), g["sphere"]["radius"].get<double>()),
                number(c["value"]));
      } else if (c.at("kind") == "distant_light") {
        const Receiver r{vec(g["receiver"]["point"]), vec(g["receiver"]["normal"]).normalized()};
        const double angle_deg = 2.0 * g["cone"]["half_angle_rad"].get<double>() * 180.0 / M_PI;
        err.add(distant_form_factor(r, vec(g["cone"]["axis"]).normalized(), angle_deg), number(c["value"]));
      }
    }
    ValidationRow row{"sphere and distant lights", "closed form", 0, 1, 0, 0, 0, since(t0)};
    err.into(row);
    emit(row);
  }

  // A receiver point under a unit square source (z = 1) with a parallel 0.4 × 0.4 blocker at
  // z = 0.5 centred over the point: seen from the point, the blocker hides the centred
  // 0.8 × 0.8 square of the source, so F = F(source) − F(shadow), both by Lambert (superposition).
  // Ray mode at a ladder of ray counts (RMS over 16 seeds), and the exact mode.
  void occluded_point() {
    const Polygon source = {{-0.5, -0.5, 1}, {-0.5, 0.5, 1}, {0.5, 0.5, 1}, {0.5, -0.5, 1}};  // faces down
    const Polygon shadow = {{-0.4, -0.4, 1}, {-0.4, 0.4, 1}, {0.4, 0.4, 1}, {0.4, -0.4, 1}};
    const Receiver recv{Vec3(0, 0, 0), Vec3::UnitZ()};
    const double unoccluded = lambert_form_factor(recv, source);
    const double want = unoccluded - lambert_form_factor(recv, shadow);
    Scene s = two_polygon_scene({{-0.2, -0.2, 0.5}, {0.2, -0.2, 0.5}, {0.2, 0.2, 0.5}, {-0.2, 0.2, 0.5}},
                                {{-0.2, -0.2, 0.5}, {-0.2, 0.2, 0.5}, {0.2, 0.2, 0.5}, {0.2, -0.2, 0.5}});
    const Vec3 n_src = -Vec3::UnitZ();
    for (VisibilityMethod method : {VisibilityMethod::Rays, VisibilityMethod::Exact}) {
      const Visibility vis(s, method);
      std::vector<int> occ;
      vis.culler().occluders(&recv.point, 1, source.data(), 4, occ);
      const std::vector<int> ladder = method == VisibilityMethod::Exact ? std::vector<int>{0}
                                      : opt_.quick                      ? std::vector<int>{16, 256}
                                                                        : std::vector<int>{16, 64, 256, 1024, 4096};
      for (int rays : ladder) {
        ErrorStats err;
        const auto t0 = Clock::now();
        RayTally cast;
        const int seeds = method == VisibilityMethod::Exact ? 1 : 16;
        for (int seed = 0; seed < seeds; ++seed)
          err.add(
              vis.point_to_patch(recv, source.data(), 4, n_src, unoccluded, occ, rays, pair_stream(seed, 7, 11), cast),
              want);
        ValidationRow row{"occluded point (blocker, superposition)",
                          method == VisibilityMethod::Exact ? "exact" : "rays=" + std::to_string(rays),
                          0,
                          1,
                          0,
                          0,
                          0,
                          since(t0) / seeds};
        err.into(row);
        emit(row);
      }
    }
  }

  // Coaxial parallel disks (Howell C-41) as inscribed m-gons with the per-pair rule: the error is
  // the tessellation's and falls as m grows.
  void coaxial_disks() {
    for (int m : opt_.quick ? std::vector<int>{8, 16} : std::vector<int>{8, 16, 32, 64, 128}) {
      ErrorStats err;
      const auto t0 = Clock::now();
      for (const auto& c : refs_.at("cases")) {
        if (c.at("id").get<std::string>().rfind("C41", 0) != 0) continue;
        const auto& g = c.at("geometry");
        auto disk = [&](const nlohmann::json& d) {
          const Vec3 centre = vec(d["center"]), n = vec(d["normal"]).normalized();
          const Vec3 u = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized(), w = n.cross(u);
          // Equal-area m-gon: the circumradius that keeps the disk's area (tessellation error O(m^-4)).
          const double r = d["radius"].get<double>() * std::sqrt(2 * M_PI / (m * std::sin(2 * M_PI / m)));
          Polygon p;
          for (int k = 0; k < m; ++k)
            p.push_back(centre + r * (std::cos(2 * M_PI * k / m) * u + std::sin(2 * M_PI * k / m) * w));
          return p;  // counter-clockwise about n
        };
        const Polygon p1 = disk(g["disk1"]), p2 = disk(g["disk2"]);
        // The per-pair rule takes triangles and quads: fan the receiver, keep the source whole.
        double f = 0.0;
        for (int k = 1; k + 1 < m; ++k) {
          const Vec3 tri[3] = {p1[0], p1[k], p1[k + 1]};
          const PairResult r = pair_form_factor(tri, 3, vec(g["disk1"]["normal"]).normalized(), p2.data(), m,
                                                vec(g["disk2"]["normal"]).normalized(), 1e-10);
          f += r.form_factor * polygon_area({tri[0], tri[1], tri[2]});
        }
        err.add(f / polygon_area(p1), number(c["value"]));
      }
      ValidationRow row{"coaxial disks (Howell C-41), m-gons", "m=" + std::to_string(m), 0, 0, 0, 0, 0, since(t0)};
      err.into(row);
      emit(row);
    }
  }

  // F(1 -> 2) between two polygons meshed n × n with q × q receiver points, against Howell
  // C-11 (parallel opposed rectangles) and C-14 (perpendicular, common edge).
  void patch_patch() {
    std::vector<const nlohmann::json*> cases;
    for (const auto& c : refs_.at("cases"))
      if (c.at("kind") == "patch_patch" && c.at("id").get<std::string>().rfind("C41", 0) != 0) cases.push_back(&c);
    const std::vector<std::pair<int, int>> ladder =
        opt_.quick ? std::vector<std::pair<int, int>>{{1, 1}, {2, 2}, {4, 4}}
                   : std::vector<std::pair<int, int>>{{1, 1}, {1, 2}, {2, 2}, {2, 4}, {4, 4}, {8, 4}, {8, 8}, {16, 8}};
    for (const auto& [n, q] : ladder) {
      ErrorStats err;
      int patches = 0;
      const auto t0 = Clock::now();
      for (const nlohmann::json* c : cases) {
        const auto& g = c->at("geometry");
        Polygon p1 = polygon(g["patch1"]["vertices"]), p2 = polygon(g["patch2"]["vertices"]);
        // Orient each patch so that its front is the given normal.
        if (polygon_normal(p1).dot(vec(g["patch1"]["normal"])) < 0) std::reverse(p1.begin(), p1.end());
        if (polygon_normal(p2).dot(vec(g["patch2"]["normal"])) < 0) std::reverse(p2.begin(), p2.end());
        const Scene s = two_polygon_scene(p1, p2);
        double longest = 0;
        for (const Polygon* p : {&p1, &p2})
          for (size_t k = 0; k < p->size(); ++k)
            longest = std::max(longest, ((*p)[(k + 1) % p->size()] - (*p)[k]).norm());
        const PatchMesh mesh = subdivide(s, {longest / n * (1 + 1e-9), 0.0});
        patches += mesh.size();
        FillOptions fo;
        fo.quadrature = q;
        FillStats st;
        const FormFactors F = fill_form_factors(mesh, fo, st);
        double a1 = 0, flux = 0;
        for (int i = 0; i < mesh.size(); ++i) {
          if (s.faces[mesh.patches[i].face].group != 0) continue;
          a1 += mesh.patches[i].area;
          for (int j = 0; j < mesh.size(); ++j)
            if (s.faces[mesh.patches[j].face].group == 1) flux += mesh.patches[i].area * F(i, j);
        }
        err.add(flux / a1, number(c->at("value")));
      }
      std::ostringstream name;
      name << "n=" << n << " q=" << q;
      ValidationRow row{"patch-to-patch (Howell C-11, C-14)", name.str(), patches, q, 0, 0, 0, since(t0)};
      err.into(row);
      emit(row);
    }
  }

  // Patch to patch with a blocker: receiver R = [-0.5, 0.5]² at z = 0 (facing up), source
  // S = [-1, 1]² at z = 1 (facing down), a two-sided 0.4 × 0.4 blocker at z = 0.5. From a
  // receiver point x the blocker's shadow on S is the square [-0.4, 0.4]² scaled about x by 2
  // (similar triangles), always inside S, so the visible factor is F(x → S) − F(x → shadow(x)),
  // both by Lambert's closed form (superposition), a smooth function of x: the reference is its
  // mean over R by 24 × 24 Gauss–Legendre (converged to rounding). The meshed receiver is filled
  // with exact visibility (shadow-volume clipping) at a ladder of receiver rules.
  void occluded_patch() {
    const Polygon R = {{-0.5, -0.5, 0}, {0.5, -0.5, 0}, {0.5, 0.5, 0}, {-0.5, 0.5, 0}};
    const Polygon S = {{-1, -1, 1}, {-1, 1, 1}, {1, 1, 1}, {1, -1, 1}};
    auto visible = [&](const Vec3& x) {
      Polygon shadow;
      for (const Vec3& c : {Vec3(-0.2, -0.2, 0.5), Vec3(-0.2, 0.2, 0.5), Vec3(0.2, 0.2, 0.5), Vec3(0.2, -0.2, 0.5)})
        shadow.push_back(x + 2.0 * (c - x));  // the ray from x through c meets z = 1 at twice the distance
      const Receiver r{x, Vec3::UnitZ()};
      return lambert_form_factor(r, S) - lambert_form_factor(r, shadow);
    };
    double want = 0.0;
    for (const QuadraturePoint& q : patch_quadrature(R.data(), 4, 24)) want += q.weight * visible(q.point);
    Scene scene;
    scene.source = "occluded_patch";
    const Polygon blocker_up = {{-0.2, -0.2, 0.5}, {0.2, -0.2, 0.5}, {0.2, 0.2, 0.5}, {-0.2, 0.2, 0.5}};
    const Polygon blocker_down(blocker_up.rbegin(), blocker_up.rend());
    int g = 0;
    for (const Polygon* p : {&R, &S, &blocker_up, &blocker_down}) {
      Face f;
      for (const Vec3& v : *p) {
        f.vertices.push_back(static_cast<int>(scene.vertices.size()));
        scene.vertices.push_back(v);
      }
      f.group = g;
      f.source_face = g++;
      scene.faces.push_back(f);
    }
    scene.materials = {Material{"grey", Rgb::Constant(0.5), Rgb::Zero()}};
    scene.groups = {"receiver", "source", "blocker", "blocker back"};
    const Visibility vis(scene, VisibilityMethod::Exact);
    for (int n : opt_.quick ? std::vector<int>{1, 4} : std::vector<int>{1, 2, 4, 8}) {
      for (int q : opt_.quick ? std::vector<int>{1, 4} : std::vector<int>{1, 2, 4, 8}) {
        const auto t0 = Clock::now();
        // Every face split to edges of at most 1/n (the receiver n × n, the source 2n × 2n).
        const PatchMesh mesh = subdivide(scene, {1.0 / n + 1e-9, 0.0});
        FillOptions fo;
        fo.quadrature = q;
        fo.visibility = &vis;
        FillStats st;
        const FormFactors F = fill_form_factors(mesh, fo, st);
        double area = 0.0, flux = 0.0;
        for (int i = 0; i < mesh.size(); ++i) {
          if (scene.faces[mesh.patches[i].face].group != 0) continue;
          area += mesh.patches[i].area;
          for (int j = 0; j < mesh.size(); ++j)
            if (scene.faces[mesh.patches[j].face].group == 1) flux += mesh.patches[i].area * F(i, j);
        }
        ErrorStats err;
        err.add(flux / area, want);
        std::ostringstream name;
        name << "n=" << n << " q=" << q;
        ValidationRow row{"occluded patch-to-patch (exact visibility)", name.str(), mesh.size(), q, 0, 0, 0, since(t0)};
        err.into(row);
        emit(row);
      }
    }
  }

  // The same cases, one patch each, with the per-pair rule at a ladder of tolerances.
  void patch_patch_adaptive() {
    for (double tol :
         opt_.quick ? std::vector<double>{1e-3, 1e-6} : std::vector<double>{1e-2, 1e-4, 1e-6, 1e-8, 1e-10}) {
      ErrorStats err;
      const auto t0 = Clock::now();
      for (const auto& c : refs_.at("cases")) {
        if (c.at("kind") != "patch_patch" || c.at("id").get<std::string>().rfind("C41", 0) == 0) continue;
        const auto& g = c.at("geometry");
        Polygon p1 = polygon(g["patch1"]["vertices"]), p2 = polygon(g["patch2"]["vertices"]);
        const Vec3 n1 = vec(g["patch1"]["normal"]), n2 = vec(g["patch2"]["normal"]);
        if (polygon_normal(p1).dot(n1) < 0) std::reverse(p1.begin(), p1.end());
        if (polygon_normal(p2).dot(n2) < 0) std::reverse(p2.begin(), p2.end());
        const PairResult r = pair_form_factor(p1.data(), int(p1.size()), n1, p2.data(), int(p2.size()), n2, tol);
        err.add(r.form_factor, number(c.at("value")));
      }
      std::ostringstream name;
      name << "tol=" << tol;
      ValidationRow row{"patch-to-patch, per-pair rule (C-11, C-14)", name.str(), 0, 0, 0, 0, 0, since(t0)};
      err.into(row);
      emit(row);
    }
  }

  // The closed cube, one patch per wall, floor emitting: exact 6 × 6 solution.
  void cube_floor_emitting() {
    const auto& c = find_case(refs_, "cube_floor_emitting_rho0.5");
    for (int q : opt_.quick ? std::vector<int>{1, 4} : std::vector<int>{1, 2, 4, 8, 16}) {
      const auto t0 = Clock::now();
      const Scene s = unit_cube_scene(0.5, 1.0, 0);
      const PatchMesh mesh = subdivide(s, {});
      FillOptions fo;
      fo.quadrature = q;
      FillStats st;
      const FormFactors F = fill_form_factors(mesh, fo, st);
      ChannelMatrix E = ChannelMatrix::Zero(6, 3), R = ChannelMatrix::Constant(6, 3, 0.5), B;
      E.row(0).setOnes();
      solve_radiosity(F, E, R, ChannelMatrix::Zero(6, 3), true, gauss_seidel_to(1e-14, 10000), B);
      ErrorStats err;
      for (int i = 0; i < 6; ++i) err.add(B(i, 0), number(c["value"][i]));
      ValidationRow row{"cube 6x6, floor emitting", "q=" + std::to_string(q), 6, q, 0, 0, 0, since(t0)};
      err.into(row);
      emit(row);
    }
  }

  // White furnace: B = E / (1 − ρ) on every patch, any mesh (refs white_furnace_cube_rho*).
  void white_furnace() {
    for (double rho : {0.5, 0.9, 0.99, 0.999}) {
      for (int n : opt_.quick ? std::vector<int>{4} : std::vector<int>{4, 8, 16}) {
        const auto t0 = Clock::now();
        const Scene s = unit_cube_scene(rho, 1.0, -1);
        const PatchMesh mesh = subdivide(s, {1.0 / n * (1 + 1e-9), 0.0});
        FillStats st;
        const FormFactors F = fill_form_factors(mesh, FillOptions{}, st);
        const int N = mesh.size();
        ChannelMatrix B;
        solve_radiosity(F, ChannelMatrix::Constant(N, 3, 1.0), ChannelMatrix::Constant(N, 3, rho),
                        ChannelMatrix::Zero(N, 3), true, gauss_seidel_to(1e-12, 1000000), B);
        ErrorStats err;
        for (int i = 0; i < N; ++i) err.add(B(i, 0), 1.0 / (1.0 - rho));
        std::ostringstream scene;
        scene << "white furnace rho=" << rho;
        ValidationRow row{scene.str(), "n=" + std::to_string(n), N, 1, 0, 0, 0, since(t0)};
        err.into(row);
        emit(row);
      }
    }
  }

  // Every solver on the white furnace (n × n per wall) at every ρ, to a 1e-10 relative residual:
  // one line per solver; the setting names ρ and the iterations used.
  void furnace_solvers() {
    const int n = opt_.quick ? 4 : 16;
    const Scene s = unit_cube_scene(0.5, 1.0, -1);
    const PatchMesh mesh = subdivide(s, {1.0 / n * (1 + 1e-9), 0.0});
    FillStats st;
    const FormFactors F = fill_form_factors(mesh, FillOptions{}, st);
    const int N = mesh.size();
    std::vector<SolverMethod> methods = {SolverMethod::GaussSeidel, SolverMethod::Sor, SolverMethod::Cg,
                                         SolverMethod::Gmres};
    if (N <= 1600) methods.push_back(SolverMethod::Direct);
    for (SolverMethod m : methods)
      for (double rho : {0.5, 0.9, 0.99, 0.999}) {
        SolverOptions so = gauss_seidel_to(1e-10, 1000000);
        so.method = m;
        so.areas.resize(N);
        for (int i = 0; i < N; ++i) so.areas[i] = mesh.patches[i].area;
        ChannelMatrix B;
        const auto t0 = Clock::now();
        const SolverReport rep =
            solve_radiosity(F, ChannelMatrix::Constant(N, 3, 1.0), ChannelMatrix::Constant(N, 3, rho),
                            ChannelMatrix::Zero(N, 3), true, so, B);
        ErrorStats err;
        for (int i = 0; i < N; ++i) err.add(B(i, 0), 1.0 / (1.0 - rho));
        std::ostringstream setting;
        setting << "rho=" << rho << " (" << rep.iterations << " it)";
        ValidationRow row{std::string("furnace solver: ") + method_name(m), setting.str(), N, 1, 0, 0, 0, since(t0)};
        err.into(row);
        emit(row);
      }
  }

  // The hierarchical method (Hanrahan, Salzman & Aupperle 1991; hierarchical/hierarchical.h) on
  // the white furnace, ρ = 0.9, one root per wall, at a ladder of ε: every leaf's B against
  // E / (1 − ρ). Its error is that of the links' form factors summed over a leaf's gathers (the
  // links are refined to ε), amplified by 1 / (1 − ρ).
  void hierarchical_furnace() {
    const double rho = 0.9;
    const Scene s = unit_cube_scene(rho, 1.0, -1);
    const PatchMesh roots = subdivide(s, {});
    const DirectLighting lights(s);
    for (double eps : opt_.quick ? std::vector<double>{1e-1, 3e-2} : std::vector<double>{1e-1, 3e-2, 1e-2, 3e-3}) {
      const auto t0 = Clock::now();
      HierarchicalOptions o;
      o.error = eps;
      HierarchicalRadiosity h(s, roots, nullptr, lights, o);
      const HierarchicalSolution sol = h.solve();
      ErrorStats err;
      for (int i = 0; i < int(sol.radiosity.rows()); ++i) err.add(sol.radiosity(i, 0), 1.0 / (1.0 - rho));
      std::ostringstream setting;
      setting << "eps=" << eps << " (" << sol.stats.links << " links)";
      ValidationRow row{"hierarchical: white furnace rho=0.9", setting.str(), sol.leaves.size(), 1, 0, 0, 0, since(t0)};
      err.into(row);
      emit(row);
    }
  }

  // Sphere enclosure with an emitting polar cap (z >= 0.5, a quarter of the area), ρ = 0.5:
  // for a true sphere F_ij = A_j / A, so B_i = E_i + ρ/(1−ρ)·Ē with Ē = 1/4: 1.25 on the cap,
  // 0.25 elsewhere (refs sphere_cap_emitting_rho0.5). Error falls as the tessellation refines.
  void sphere_cap() {
    const auto& c = find_case(refs_, "sphere_cap_emitting_rho0.5");
    const double cap = number(c["value"][0]), rest = number(c["value"][1]);
    for (int rings : opt_.quick ? std::vector<int>{6, 12} : std::vector<int>{6, 12, 24, 48}) {
      const auto t0 = Clock::now();
      const Scene s = sphere_cap_scene(rings, 0.5);
      const PatchMesh mesh = subdivide(s, {});
      FillStats st;
      const FormFactors F = fill_form_factors(mesh, FillOptions{}, st);
      const int N = mesh.size();
      ChannelMatrix E = ChannelMatrix::Zero(N, 3), B;
      for (int i = 0; i < N; ++i)
        if (s.faces[mesh.patches[i].face].material == 1) E.row(i).setOnes();
      solve_radiosity(F, E, ChannelMatrix::Constant(N, 3, 0.5), ChannelMatrix::Zero(N, 3), true,
                      gauss_seidel_to(1e-12, 100000), B);
      ErrorStats err;
      for (int i = 0; i < N; ++i) err.add(B(i, 0), s.faces[mesh.patches[i].face].material == 1 ? cap : rest);
      ValidationRow row{"sphere enclosure, emitting cap", std::to_string(rings) + " rings", N, 1, 0, 0, 0, since(t0)};
      err.into(row);
      emit(row);
    }
  }
};

// True when the file at `path` ends with a PNG IEND chunk: length 0, "IEND", CRC AE 42 60 82.
bool png_is_complete(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in || in.tellg() < 20) return false;
  in.seekg(-12, std::ios::end);
  char tail[12];
  if (!in.read(tail, sizeof tail)) return false;
  static const unsigned char iend[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xAE, 0x42, 0x60, 0x82};
  return std::equal(tail, tail + 12, iend, [](char a, unsigned char b) { return static_cast<unsigned char>(a) == b; });
}

}  // namespace

std::vector<ValidationRow> run_validation(const nlohmann::json& refs, const ValidationOptions& options) {
  return Suite(refs, options).run();
}

void write_validation_csv(const std::string& path, const std::vector<ValidationRow>& rows) {
  AtomicOutput out(path);
  write_validation_csv(out, rows);
  out.commit();
}

void write_validation_csv(AtomicOutput& out, const std::vector<ValidationRow>& rows) {
  {
    std::ofstream& f = out.stream();
    f << "scene,setting,patches,quadrature,cases,max_rel_error,rms_rel_error,seconds\n" << std::setprecision(6);
    for (const auto& r : rows)
      f << '"' << r.scene << "\",\"" << r.setting << "\"," << r.patches << ',' << r.quadrature << ',' << r.cases << ','
        << r.max_rel_error << ',' << r.rms_rel_error << ',' << r.seconds << '\n';
  }
}

void write_validation_markdown(AtomicOutput& out, const std::vector<ValidationRow>& rows) {
  {
    std::ofstream& f = out.stream();
    f << "| scene | setting | patches | cases | max rel. error | RMS rel. error | seconds |\n"
      << "|---|---|---:|---:|---:|---:|---:|\n";
    for (const auto& r : rows) {
      f << "| " << r.scene << " | " << r.setting << " | " << r.patches << " | " << r.cases << " | " << std::scientific
        << std::setprecision(2) << r.max_rel_error << " | " << r.rms_rel_error << " | " << std::defaultfloat
        << std::setprecision(3) << r.seconds << " |\n";
    }
  }
}

void write_error_vs_time_plot(const std::string& csv_path, const std::string& png_path,
                              const std::vector<ValidationRow>& rows) {
  AtomicOutput png(png_path);
  write_error_vs_time_plot(png, csv_path, rows);
  png.commit();
}

void write_error_vs_time_plot(AtomicOutput& png, const std::string& title, const std::vector<ValidationRow>& rows) {
  const std::string& png_path = png.target();
  // One data block per scene (gnuplot "index"), errors floored at 1e-17 so exact zeros plot.
  AtomicOutput data(png_path + ".dat");
  std::vector<std::string> scenes;
  {
    std::ofstream& f = data.stream();
    std::map<std::string, std::vector<const ValidationRow*>> by_scene;
    for (const auto& r : rows) {
      if (!by_scene.count(r.scene)) scenes.push_back(r.scene);
      by_scene[r.scene].push_back(&r);
    }
    for (const auto& s : scenes) {
      for (const ValidationRow* r : by_scene[s])
        f << std::max(r->seconds, 1e-7) << ' ' << std::max(r->max_rel_error, 1e-17) << '\n';
      f << "\n\n";
    }
  }
  data.finish();  // gnuplot reads it next: every byte must be there
  AtomicOutput script(png_path + ".gp");
  script.stream() << "set terminal pngcairo size 1100,700 font ',10'\n"
                  << "set output '" << png.temp_path() << "'\n"
                  << "set logscale xy\nset format y '10^{%L}'\nset format x '10^{%L}'\n"
                  << "set xlabel 'wall time (s)'\nset ylabel 'max relative error'\n"
                  << "set title 'Photometria validation: error against run time (" << title << ")'\n"
                  << "set key outside right\nset grid\n"
                  << "plot ";
  for (size_t k = 0; k < scenes.size(); ++k)
    script.stream() << (k ? ", " : "") << "'" << data.temp_path() << "' index " << k << " with linespoints lw 2 title '"
                    << scenes[k] << "'";
  script.stream() << "\nunset output\n";  // closes the PNG: cairo writes its last bytes here
  script.finish();
  // gnuplot's messages are read back (never passed to our stdout) so that a failure is one line.
  FILE* gp = popen(("gnuplot '" + script.temp_path() + "' 2>&1").c_str(), "r");
  if (!gp) throw_io("cannot write '" + png_path + "': cannot run gnuplot (install gnuplot-nox)");
  std::string messages;
  char buf[512];
  while (std::fgets(buf, sizeof buf, gp)) messages += buf;
  const int status = pclose(gp);
  const std::string first_message = messages.substr(0, messages.find('\n'));
  if (status != 0)
    throw_io("cannot write '" + png_path + "': gnuplot failed" +
             (WIFEXITED(status) && WEXITSTATUS(status) == 127 ? std::string(" (install gnuplot-nox)")
              : first_message.empty()                         ? ""
                                                              : ": " + first_message));
  // gnuplot does not report a short write (it exits 0 on a full disk): a PNG is complete only
  // when it ends with its IEND chunk (PNG specification, ISO/IEC 15948, sec. 11.2.5).
  if (!png_is_complete(png.temp_path()))
    throw_io("cannot write '" + png_path + "': the picture gnuplot wrote is incomplete (disk full?)");
}

}  // namespace photometria::validation
