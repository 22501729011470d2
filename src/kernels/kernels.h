// Every point-to-polygon form-factor formulation behind one interface.
//
//   name            exact  source (docs/kernels.md has the theory and the stability table)
//   iwanicki        yes    Iwanicki Ω/sin Ω form, centred evaluation        — the DEFAULT
//   lambert         yes    Heitz 2017 eq. (1) / Stark 2000 eq. (3), atan2
//   stark-vertex    yes    Stark 2000 eqs. (12)–(13)
//   stark-image     yes    Stark 2000 eqs. (8)–(10) in homogeneous form (44)–(46), Fig. 10–11
//   point-source    no     Lawlor 2007 inverse-square law
//   tampieri        no     Lawlor 2007 Hottel–Sarofim / Tampieri vector form (acos, unclipped)
//   cross-product   no     Lawlor 2007 cross-product approximation for distant receivers
//
// Sources: M. Iwanicki, "Deriving the analytical formula for a diffuse response from a polygonal
// light source" (Activision, technical note); E. Heitz, "Geometric Derivation of the Irradiance
// of Polygonal Lights" (Unity Technologies, 2017); M. M. Stark, "Vertex-Based Formulations of
// Irradiance from Polygonal Sources" (University of Utah, UUCS-00-012, 2000); O. Lawlor,
// "Radiosity Units & Computation" (lecture notes, University of Alaska Fairbanks, 2007). Full
// entries in docs/theory.md "References".
//
// Spheres and distant lights have their own kernels (sphere.h, distant.h), not listed here.
// The default is the most accurate formulation: iwanicki agrees with the others to ~1e-15 and
// keeps ~15 digits for a polygon 1e6 sizes away, where the plain edge sums keep ~10.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kernels/lambert.h"

namespace photometria {

enum class Kernel { Iwanicki, Lambert, StarkVertex, StarkImage, PointSource, Tampieri, CrossProduct };

struct KernelInfo {
  Kernel kernel;
  const char* name;    // command-line name (--kernel)
  bool exact;          // false: an approximation, reported with its error
  const char* source;  // one line: paper and equation numbers
};

// All polygon kernels, the default first.
const std::vector<KernelInfo>& polygon_kernels();
const KernelInfo& kernel_info(Kernel kernel);
constexpr Kernel kDefaultKernel = Kernel::Iwanicki;

// The kernel called `name`, or nothing if there is none.
std::optional<Kernel> kernel_from_name(std::string_view name);
// "iwanicki, lambert, ..." for messages.
std::string kernel_names();

// F(dA → polygon) with the chosen formulation. `polygon` has n vertices, counter-clockwise seen
// from its front; the receiver's normal is unit length. Exact kernels return a value in [0, 1].
double point_form_factor(Kernel kernel, const Receiver& receiver, const Vec3* polygon, int n);
inline double point_form_factor(Kernel kernel, const Receiver& receiver, const Polygon& polygon) {
  return point_form_factor(kernel, receiver, polygon.data(), static_cast<int>(polygon.size()));
}

}  // namespace photometria
