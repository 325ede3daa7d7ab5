#include "alphainv/model/inertia_model.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

TEST(InertiaModel, Eq6AtKnownAngles) {
  InertiaModel m{1.0, 2.0, 3.0, 4.0, 0.0};
  // γ1 = 0, γ2 = π: ψ = 0 → I = 1 + 2 + 3 + 4.
  EXPECT_NEAR(m.inertia(0.0, kPi), 10.0, 1e-12);
  // γ1 = π/2: cos γ1 = 0 → I = 1 + 3 cos²ψ with ψ = π − π/2 − γ2.
  EXPECT_NEAR(m.inertia(kPi / 2, kPi / 2), 1.0 + 3.0, 1e-12);
  m.gamma_offs_rad = 0.3;
  const double psi = kPi - 0.2 - 1.1 - 0.3;
  EXPECT_NEAR(m.inertia(0.2, 1.1),
              1.0 + 2.0 * std::pow(std::cos(0.2), 2) + 3.0 * std::pow(std::cos(psi), 2) +
                  4.0 * std::cos(0.2) * std::cos(psi),
              1e-12);
}

TEST(InertiaModel, PaperParametersGiveTable10Inertia) {
  // 65°/90° pose, true angles 60.08°, 87.00°: I = 0.004366 = 1/229.04 (Table 10, Table 5).
  const LinearModel lin = paper_linear_model();
  const double i = lin.inertia.inertia(deg_to_rad(60.08), deg_to_rad(87.00));
  EXPECT_NEAR(i, 0.004366, 0.0005 * 0.004366);
  EXPECT_NEAR(lin.beta_tilde(i), 229.04, 0.001 * 229.04);  // eq. (25)
  EXPECT_NEAR(lin.damping(i), 6.242, 0.001 * 6.242);       // eq. (24)
}

TEST(InertiaModel, DegreeConversionRoundTrips) {
  EXPECT_NEAR(rad_to_deg(deg_to_rad(37.5)), 37.5, 1e-12);
  EXPECT_NEAR(deg_to_rad(180.0), kPi, 1e-15);
}

}  // namespace
}  // namespace alphainv
