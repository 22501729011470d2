#include "kernels/kernels.h"

#include "kernels/approximations.h"
#include "kernels/iwanicki.h"
#include "kernels/stark.h"

namespace photometria {

const std::vector<KernelInfo>& polygon_kernels() {
  static const std::vector<KernelInfo> list = {
      {Kernel::Iwanicki, "iwanicki", true, "Iwanicki, final formula (Omega/sin Omega), centred evaluation"},
      {Kernel::Lambert, "lambert", true, "Heitz 2017 eq. (1), Stark 2000 eq. (3)"},
      {Kernel::StarkVertex, "stark-vertex", true, "Stark 2000 eqs. (12)-(13)"},
      {Kernel::StarkImage, "stark-image", true, "Stark 2000 eqs. (8)-(10), homogeneous form eqs. (44)-(46), Fig. 11"},
      {Kernel::PointSource, "point-source", false, "Lawlor 2007 inverse-square point source"},
      {Kernel::Tampieri, "tampieri", false, "Lawlor 2007 Hottel-Sarofim / Tampieri vector form"},
      {Kernel::CrossProduct, "cross-product", false, "Lawlor 2007 cross-product approximation"},
  };
  return list;
}

const KernelInfo& kernel_info(Kernel kernel) {
  for (const KernelInfo& k : polygon_kernels())
    if (k.kernel == kernel) return k;
  return polygon_kernels().front();
}

std::optional<Kernel> kernel_from_name(std::string_view name) {
  for (const KernelInfo& k : polygon_kernels())
    if (name == k.name) return k.kernel;
  return std::nullopt;
}

std::string kernel_names() {
  std::string s;
  for (const KernelInfo& k : polygon_kernels()) s += (s.empty() ? "" : ", ") + std::string(k.name);
  return s;
}

double point_form_factor(Kernel kernel, const Receiver& r, const Vec3* v, int n) {
  switch (kernel) {
    case Kernel::Iwanicki: return iwanicki_form_factor(r, v, n);
    case Kernel::Lambert: return lambert_form_factor(r, v, n);
    case Kernel::StarkVertex: return stark_vertex_form_factor(r, v, n);
    case Kernel::StarkImage: return stark_image_form_factor(r, v, n);
    case Kernel::PointSource: return point_source_form_factor(r, v, n);
    case Kernel::Tampieri: return tampieri_form_factor(r, v, n);
    case Kernel::CrossProduct: return cross_product_form_factor(r, v, n);
  }
  return 0.0;
}

}  // namespace photometria
