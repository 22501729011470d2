// Sphere and distant lights (kernels/sphere.h, distant.h, lights.h): every sphere_light and
// distant_light reference, the regimes above / crossing / below the horizon, θmax = 0, tiny,
// π/2 and > π/2, the UsdLux normalization (OpenUSD note "Normalizing Distant Lights – In
// Depth", see kernels/distant.h) and the scene-file "lights" reader.
#include <gtest/gtest.h>

#include <cmath>

#include "kernels/distant.h"
#include "kernels/lights.h"
#include "kernels/sphere.h"
#include "refs.h"
#include "util/error.h"

using namespace photometria;

namespace {

void expect_rel(double got, long double want, double tol, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_TRUE(std::isfinite(got));
  if (want == 0) EXPECT_EQ(got, 0.0);
  else EXPECT_LE(std::abs((got - want) / want), tol) << got << " vs " << double(want);
}

Receiver receiver_of(const nlohmann::json& g) {
  return {refs::vec(g["receiver"]["point"]), refs::vec(g["receiver"]["normal"]).normalized()};
}

}  // namespace

TEST(SphereLight, EveryReference) {
  int n = 0;
  for (const auto& c : refs::all()["cases"]) {
    if (c["kind"] != "sphere_light") continue;
    const auto& g = c["geometry"];
    expect_rel(
        sphere_form_factor(receiver_of(g), refs::vec(g["sphere"]["center"]), g["sphere"]["radius"].get<double>()),
        refs::number(c["value"]), 1e-12, c["id"].get<std::string>());
    ++n;
  }
  EXPECT_EQ(n, 7);
}

TEST(DistantLight, EveryReference) {
  int n = 0;
  for (const auto& c : refs::all()["cases"]) {
    if (c["kind"] != "distant_light") continue;
    const auto& g = c["geometry"];
    const double angle_deg = 2.0 * g["cone"]["half_angle_rad"].get<double>() * 180.0 / M_PI;
    expect_rel(distant_form_factor(receiver_of(g), refs::vec(g["cone"]["axis"]), angle_deg), refs::number(c["value"]),
               1e-12, c["id"].get<std::string>());
    ++n;
  }
  EXPECT_EQ(n, 4);
}

// Independent values: (1/π)∫ max(0, N·ω) dω over the cap, integrated in direction space with
// mpmath at 40 digits (polar angle θ around the axis by Gauss–Legendre/tanh-sinh, the azimuth in
// closed form, split at the kinks θ = |β| and π − |β|). σ = half-angle, β = elevation of the axis.
TEST(SphericalCap, CrossingTheHorizonKeepsItsDigits) {
  struct Case {
    const char* name;
    long double sigma, beta, value;
  };
  const Case cases[] = {
      {"sun disc, centre 0.002 rad above the horizon", 0.00465L, 0.002L, 4.87858983277202680248587078006e-8L},
      {"sun disc, centre 0.002 rad below the horizon", 0.00465L, -0.002L, 5.54123884494561435186810805207e-9L},
      {"tiny cap 1e-6 rad", 1e-6L, 3e-7L, 3.90637639317824379942714334766e-19L},
      {"near tangency from above", 0.3L, 0.2999L, 0.0258000843104365865074940329039L},
      {"wider than a hemisphere: 240 deg, axis 30 deg up", 2.094395102393195492308429L, 0.5235987755982988730771072L,
       0.955387772546419620093898513195L},
      {"wider than a hemisphere: 200 deg, axis 45 deg down", 1.745329251994329576923691L, -0.7853981633974483096156608L,
       0.235279124533045096344837249578L},
  };
  for (const Case& c : cases) {
    const double f =
        spherical_cap_form_factor(double(std::sin(c.sigma)), double(std::cos(c.sigma)), double(std::sin(c.beta)));
    expect_rel(f, c.value, 1e-12, c.name);
    // The same through the distant light: cone axis at elevation β seen by an upward receiver.
    const Vec3 axis(double(std::cos(c.beta)), 0.0, double(std::sin(c.beta)));
    expect_rel(distant_form_factor({Vec3::Zero(), Vec3::UnitZ()}, axis, double(c.sigma * 360 / M_PIl)), c.value, 1e-12,
               std::string(c.name) + " (distant)");
  }
  // A sphere r = 1 at d = 1e4 whose centre is 5e-5 rad below the horizon (same quadrature).
  const double d = 1e4, beta = std::asin(-5e-5);
  const Vec3 centre = d * Vec3(std::cos(beta), 0.0, std::sin(beta));
  expect_rel(sphere_form_factor({Vec3::Zero(), Vec3::UnitZ()}, centre, 1.0), 4.0081669426627857789999554737e-14L, 1e-10,
             "far sphere crossing");
}

TEST(SphericalCap, RegimesAndLimits) {
  const Receiver up{Vec3::Zero(), Vec3::UnitZ()};
  // Wholly above: r²/d² cos α (Heitz 2017 eq. 16, see kernels/sphere.h); wholly below: 0;
  // a 1e6 offset changes nothing.
  EXPECT_DOUBLE_EQ(sphere_form_factor(up, Vec3(1.8, 0, 2.4), 1.0), 0.8 / 9.0);
  EXPECT_EQ(sphere_form_factor(up, Vec3(1.8, 0, -2.4), 1.0), 0.0);
  const Vec3 off(1e6, -1e6, 1e6);
  // (dyadic offsets, so that the shifted input is the same geometry exactly)
  EXPECT_NEAR(sphere_form_factor({off, Vec3::UnitZ()}, off + Vec3(2.5, 0, 0.75), 1.0),
              sphere_form_factor(up, Vec3(2.5, 0, 0.75), 1.0), 1e-12 * 0.05);
  // θmax = 0: nothing; θmax = π/2 (angle 180°): a hemisphere around the axis, F = (1 + cos α)/2.
  EXPECT_EQ(distant_form_factor(up, Vec3::UnitZ(), 0.0), 0.0);
  for (double alpha : {0.0, 0.3, 1.0, M_PI / 2, 2.5, M_PI}) {
    const Vec3 axis(std::sin(alpha), 0, std::cos(alpha));
    EXPECT_NEAR(distant_form_factor(up, axis, 180.0), 0.5 * (1 + std::cos(alpha)), 1e-15) << alpha;
    // 360°: the whole sphere of directions, F = 1 whatever the axis.
    EXPECT_NEAR(distant_form_factor(up, axis, 360.0), 1.0, 1e-15) << alpha;
  }
  // Complement identity for σ > π/2: F(σ, A) + F(π − σ, −A)... = 1 − F(π − σ, −A) by construction;
  // check continuity across σ = π/2 instead.
  const Vec3 axis = Vec3(0.6, 0, 0.8);
  EXPECT_NEAR(distant_form_factor(up, axis, 180.0 - 1e-9), distant_form_factor(up, axis, 180.0 + 1e-9), 1e-10);
  // Receiver on the sphere's surface: the limit from outside.
  EXPECT_NEAR(sphere_form_factor(up, Vec3(0, 0, 1), 1.0), 1.0, 1e-15);
  // Continuity at the boundaries of the crossing branch (β = ±σ).
  const double s = std::sin(0.3), c = std::cos(0.3);
  EXPECT_NEAR(spherical_cap_form_factor(s, c, s * (1 - 1e-12)), s * s * s, 1e-12);
  EXPECT_NEAR(spherical_cap_form_factor(s, c, -s * (1 - 1e-12)), 0.0, 1e-15);
}

// Seed 001: with normalize on, intensity = illuminance on a surface facing the light for any
// θmax <= π/2; for θmax > π/2 the normalization is two-sided (∫ L |cos θ| dω), so the one-sided
// irradiance of a facing surface is intensity / (2 − sin²θmax).
TEST(DistantLight, UsdLuxNormalization) {
  const Receiver facing{Vec3::Zero(), Vec3(0, 0.6, 0.8)};
  for (double angle : {0.0, 1e-6, 0.53, 10.0, 90.0, 179.0, 180.0}) {
    EXPECT_NEAR(distant_irradiance(facing, Vec3(0, 0.6, 0.8), angle, 1000.0, true), 1000.0, 1e-9) << angle;
  }
  for (double angle : {200.0, 270.0, 359.0}) {
    const double s = std::sin(angle / 2 * M_PI / 180);
    EXPECT_NEAR(distant_irradiance(facing, Vec3(0, 0.6, 0.8), angle, 1000.0, true), 1000.0 / (2 - s * s), 1e-9)
        << angle;
  }
  EXPECT_NEAR(distant_size_factor(0.0), 1.0, 0);
  EXPECT_NEAR(distant_size_factor(180.0), M_PI, 1e-15);
  EXPECT_NEAR(distant_size_factor(240.0), M_PI * (2 - 0.75), 1e-14);
  // Without normalize, intensity is the radiance: E = π F L; a delta light (angle 0): E = I cos α.
  EXPECT_NEAR(distant_irradiance({Vec3::Zero(), Vec3::UnitZ()}, Vec3::UnitZ(), 60.0, 2.0, false), 2.0 * M_PI * 0.25,
              1e-14);
  EXPECT_NEAR(distant_irradiance({Vec3::Zero(), Vec3::UnitZ()}, Vec3(0.6, 0, 0.8), 0.0, 5.0, false), 4.0, 1e-15);
  EXPECT_EQ(distant_irradiance({Vec3::Zero(), Vec3::UnitZ()}, Vec3(0.6, 0, -0.8), 0.0, 5.0, true), 0.0);
}

TEST(Lights, ParseAndDirectIrradiance) {
  const auto j = nlohmann::json::parse(R"([
    {"type": "sphere", "center": [0, 0, 2], "radius": 1, "intensity": [100, 50, 0]},
    {"type": "distant", "direction": [0, 0, 2], "angle": 0.53, "intensity": 1000, "normalize": true}])");
  const auto lights = parse_lights(j, "scene.json");
  ASSERT_EQ(lights.size(), 2u);
  const Receiver r{Vec3::Zero(), Vec3::UnitZ()};
  const Eigen::Array3d h0 = direct_irradiance(r, lights[0]);  // F = 1/4 (refs sl_frontal_B39)
  EXPECT_NEAR(h0[0], 25.0, 1e-13);
  EXPECT_NEAR(h0[1], 12.5, 1e-13);
  EXPECT_EQ(h0[2], 0.0);
  EXPECT_TRUE(lights[1].direction.isApprox(Vec3::UnitZ()));
  EXPECT_NEAR(direct_irradiance(r, lights[1])[1], 1000.0, 1e-9);
}

TEST(Lights, ErrorsNameTheLightIndex) {
  auto message = [](const char* text) {
    try {
      parse_lights(nlohmann::json::parse(text), "scene.json");
    } catch (const Error& e) {
      EXPECT_EQ(e.exit_code(), 1);
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(
      message(R"([{"type": "sphere", "center": [0,0,1], "radius": -1, "intensity": 1}])").find("lights[0]: 'radius'"),
      std::string::npos);
  EXPECT_NE(message(R"([{"type":"sphere","center":[0,0,1],"radius":1,"intensity":1},{"type":"spot","intensity":1}])")
                .find("lights[1]: 'type'"),
            std::string::npos);
  EXPECT_NE(message(R"([{"type": "distant", "direction": [0,0,0], "intensity": 1}])").find("lights[0]: 'direction'"),
            std::string::npos);
  EXPECT_NE(message(R"([{"type": "distant", "direction": [0,0,1], "angle": 400, "intensity": 1}])").find("'angle'"),
            std::string::npos);
  EXPECT_NE(message(R"([{"type": "distant", "direction": [0,0,1], "intensity": 1, "colour": 1}])")
                .find("unknown key 'colour'"),
            std::string::npos);
  EXPECT_NE(message(R"([{"type": "sphere", "center": [0,0,1], "radius": 1}])").find("'intensity' is missing"),
            std::string::npos);
}
