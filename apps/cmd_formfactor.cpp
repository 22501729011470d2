// `photometria formfactor QUERIES.json [--kernel NAME]`: point-to-polygon / sphere / distant
// form factors, one JSON object per line on stdout, 17 significant digits.
#include <cmath>
#include <iostream>
#include <memory>

#include "commands.h"
#include "io/queries.h"
#include "kernels/distant.h"
#include "kernels/kernels.h"
#include "kernels/sphere.h"
#include "util/error.h"

namespace pm = photometria;

namespace {

struct FormFactorArgs {
  std::string queries;
  std::string kernel = pm::kernel_info(pm::kDefaultKernel).name;
};

std::string line_for(const pm::PointQuery& q, pm::Kernel kernel) {
  const pm::Receiver r{q.point, q.normal};
  std::string out = "{\"id\": " + pm::json_string(q.id);
  switch (q.kind) {
    case pm::PointQuery::Kind::Polygon: {
      const double f = pm::point_form_factor(kernel, r, q.polygon);
      out += ", \"form_factor\": " + pm::format_double(f);
      if (!pm::kernel_info(kernel).exact) {
        // An approximation: its error against the default (exact) kernel, never hidden.
        const double exact = pm::point_form_factor(pm::kDefaultKernel, r, q.polygon);
        out += ", \"kernel\": " + pm::json_string(pm::kernel_info(kernel).name);
        out += ", \"exact\": " + pm::format_double(exact);
        out += ", \"error\": " + pm::format_double(f - exact);
        out += ", \"relative_error\": " + (exact != 0.0 ? pm::format_double((f - exact) / exact) : std::string("null"));
      }
      break;
    }
    case pm::PointQuery::Kind::Sphere: {
      const double f = pm::sphere_form_factor(r, q.center, q.radius);
      out += ", \"form_factor\": " + pm::format_double(f);
      if (q.intensity) out += ", \"irradiance\": " + pm::format_double(f * *q.intensity);
      break;
    }
    case pm::PointQuery::Kind::Distant: {
      out += ", \"form_factor\": " + pm::format_double(pm::distant_form_factor(r, q.direction, q.angle_deg));
      if (q.intensity)
        out += ", \"irradiance\": " +
               pm::format_double(pm::distant_irradiance(r, q.direction, q.angle_deg, *q.intensity, q.normalize));
      break;
    }
  }
  return out + "}";
}

}  // namespace

Command add_formfactor_command(CLI::App& app) {
  auto args = std::make_shared<FormFactorArgs>();
  CLI::App* sub = app.add_subcommand(
      "formfactor",
      "Form factor (irradiance per unit exitance) from points to polygons, spheres and distant lights; "
      "one JSON object per line");
  sub->add_option("QUERIES", args->queries, "queries file (.json), format in docs/usage.md")->required();
  sub->add_option("--kernel", args->kernel,
                  "polygon formulation: " + pm::kernel_names() + " (default: " + args->kernel +
                      ", the most accurate; approximations print their error)");
  return {
      sub, [args]() {
        const auto kernel = pm::kernel_from_name(args->kernel);
        if (!kernel)
          pm::throw_bad_input("--kernel: unknown kernel '" + args->kernel + "' (one of: " + pm::kernel_names() + ")");
        const std::vector<pm::PointQuery> queries = pm::load_queries(args->queries);
        std::string text;
        for (const pm::PointQuery& q : queries) text += line_for(q, *kernel) + "\n";
        std::cout << text << std::flush;
        return 0;
      }};
}
