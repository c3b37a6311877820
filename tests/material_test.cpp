// Cable materials: the 5th-order fit, monotonicity, the measured range, files.
#include "model/material.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "model/errors.hpp"

namespace tensegrity {
namespace {

const std::array<double, 6> kKnown = {0.01, 2.0, -1.5, 3.0, 0.5, 0.2};  // increasing on [0, 1]

double known(double eps) {
  double v = 0.0;
  for (int k = 5; k >= 0; --k) v = v * eps + kKnown[k];
  return v;
}

std::vector<StrainForcePoint> samples(double lo, double hi, int n, double (*f)(double)) {
  std::vector<StrainForcePoint> p;
  for (int i = 0; i < n; ++i) {
    const double eps = lo + (hi - lo) * i / (n - 1);
    p.push_back({eps, f(eps)});
  }
  return p;
}

TEST(MaterialFit, ReproducesAKnownQuinticFromItsSamples) {
  for (const auto& [lo, hi] : {std::pair{0.0, 1.0}, std::pair{0.05, 0.95}, std::pair{0.2, 0.6}}) {
    const MaterialFit fit = fit_material(samples(lo, hi, 25, known), "known", "samples");
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(fit.material.coefficients[k], kKnown[k], 1e-8) << "k " << k << " on " << lo;
    EXPECT_LT(fit.max_residual, 1e-12);
    EXPECT_LT(fit.rms_residual, 1e-12);
    EXPECT_DOUBLE_EQ(fit.material.strain_min, lo);
    EXPECT_DOUBLE_EQ(fit.material.strain_max, hi);
    // F' of the known curve at 0.25: 2 - 0.75 + 0.5625 + 0.03125 + 0.00390625.
    EXPECT_NEAR(fit.material.slope_unchecked(0.25), 1.84765625, 1e-7);
  }
}

TEST(MaterialFit, ResidualsOfANoisyFitAreTheLeastSquaresOnes) {
  // Alternating +-d on a quintic: the fit cannot absorb it all, and its rms
  // residual cannot exceed d (the known curve itself achieves exactly d).
  std::vector<StrainForcePoint> p = samples(0.0, 1.0, 40, known);
  const double d = 0.01;
  for (std::size_t i = 0; i < p.size(); ++i) p[i].force += (i % 2 ? d : -d);
  const MaterialFit fit = fit_material(p, "noisy", "samples");
  EXPECT_LE(fit.rms_residual, d + 1e-15);
  EXPECT_GT(fit.rms_residual, 0.9 * d);
  double sum = 0.0;
  for (const auto& q : p) sum += std::pow(fit.material.force_unchecked(q.strain) - q.force, 2);
  EXPECT_NEAR(fit.rms_residual, std::sqrt(sum / p.size()), 1e-15);
}

TEST(MaterialFit, RejectsNonMonotoneData) {
  auto wave = [](double eps) { return std::sin(6.0 * eps); };  // rises then falls
  EXPECT_THROW(fit_material(samples(0.0, 1.0, 30, wave), "wave", "wave.csv"), InputError);
  try {
    fit_material(samples(0.0, 1.0, 30, wave), "wave", "wave.csv");
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "wave.csv");
    EXPECT_NE(e.reason().find("not strictly increasing"), std::string::npos) << e.what();
  }
  // A curve with a flat point (F' has a double root at 0.5) is rejected too.
  auto flat = [](double eps) { return std::pow(eps - 0.5, 3); };
  EXPECT_THROW(fit_material(samples(0.0, 1.0, 30, flat), "flat", "flat.csv"), InputError);
}

TEST(MaterialFit, NeedsSixDistinctStrains) {
  std::vector<StrainForcePoint> p = samples(0.0, 1.0, 5, known);
  p.push_back(p.back());
  p.push_back(p.front());
  EXPECT_THROW(fit_material(p, "few", "few.csv"), InputError);
}

CableMaterial known_material() {
  CableMaterial m;
  m.name = "known";
  m.diameter = 1e-3;
  m.linear_density = 1e-3;
  m.coefficients = kKnown;
  m.strain_min = 0.0;
  m.strain_max = 1.0;
  return m;
}

TEST(Material, StrainBeyondTheMeasuredRangeIsAnError) {
  const CableMaterial m = known_material();
  EXPECT_DOUBLE_EQ(m.force(0.5), known(0.5));
  EXPECT_DOUBLE_EQ(m.force(1.0), known(1.0));
  EXPECT_THROW(m.force(1.0 + 1e-12), InputError);
  EXPECT_THROW(m.force(-0.01), InputError);
  EXPECT_THROW(m.force(std::nan("")), InputError);
}

TEST(Material, RealRootsFromTheCompanionMatrix) {
  // (t - 0.2)(t - 0.5)(t + 3) = (t^2 - 0.7 t + 0.1)(t + 3) = t^3 + 2.3 t^2 - 2 t + 0.3.
  const std::vector<double> b = {0.3, -2.0, 2.3, 1.0};
  const auto r = real_polynomial_roots(b, 0.0, 1.0);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_NEAR(r[0], 0.2, 1e-14);
  EXPECT_NEAR(r[1], 0.5, 1e-14);
  EXPECT_EQ(real_polynomial_roots(b, -5.0, 5.0).size(), 3u);
  EXPECT_TRUE(real_polynomial_roots({1.0, 0.0, 1.0}, -10, 10).empty());  // t^2 + 1
}

TEST(Material, MonotonicityCheckFindsANegativeSlopeBetweenGridPoints) {
  CableMaterial m = known_material();
  EXPECT_FALSE(monotonicity_problem(m).has_value());
  // F = (eps - c)^3 - 1e-9 eps: F' = 3 (eps - c)^2 - 1e-9 < 0 only on
  // |eps - c| < 1.8e-5, between two grid points; the roots of F' catch it.
  const double c = 0.30013;
  m.coefficients = {0.0, 3 * c * c - 1e-9, -3 * c, 1.0, 0.0, 0.0};
  ASSERT_LT(m.slope_unchecked(c), 0.0);
  ASSERT_GT(m.slope_unchecked(0.3), 0.0);
  ASSERT_GT(m.slope_unchecked(0.3005), 0.0);
  EXPECT_TRUE(monotonicity_problem(m).has_value());
}

TEST(MaterialFile, RoundTripAndValidation) {
  const CableMaterial m = known_material();
  const CableMaterial back = material_from_json(material_to_json(m), "mem");
  EXPECT_EQ(back.coefficients, m.coefficients);
  EXPECT_EQ(back.strain_max, m.strain_max);
  auto j = material_to_json(m);
  j["coefficients"] = {0.0, 1.0, -3.0, 0.0, 0.0, 0.0};  // F' = 1 - 6 eps < 0 beyond 1/6
  EXPECT_THROW(material_from_json(j, "bad.json"), InputError);
  j = material_to_json(m);
  j["strain_range"] = {0.5, 0.5};
  EXPECT_THROW(material_from_json(j, "bad.json"), InputError);
  j = material_to_json(m);
  j["coefficients"] = {0.0, 1.0};
  EXPECT_THROW(material_from_json(j, "bad.json"), InputError);
  j = material_to_json(m);
  j.erase("diameter");
  EXPECT_THROW(material_from_json(j, "bad.json"), InputError);
}

TEST(MaterialFile, ShippedMaterialsAreFitsOfTheirPoints) {
  const std::filesystem::path dir = std::filesystem::path(TENSEGRITY_SOURCE_DIR) / "data" / "materials";
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string file = entry.path().filename().string();
    if (!file.ends_with(".json")) continue;
    ++count;
    const CableMaterial m = read_material_file(entry.path().string());
    EXPECT_EQ(m.name + ".json", file);
    const auto points = dir / (m.name + ".points.csv");
    ASSERT_TRUE(std::filesystem::exists(points)) << points;
    const MeasuredPoints p = read_points_csv(points.string());
    const MaterialFit fit = fit_material(p.points, m.name, points.string());
    for (int k = 0; k < 6; ++k)
      EXPECT_NEAR(fit.material.coefficients[k], m.coefficients[k], 1e-9 * (1.0 + std::abs(m.coefficients[k])));
    EXPECT_EQ(fit.material.strain_min, m.strain_min);
    EXPECT_EQ(fit.material.strain_max, m.strain_max);
    // A plausible elastic cord: a few newtons or more at 100 % strain.
    EXPECT_GT(m.force_max(), 1.0);
    EXPECT_LT(fit.rms_residual, 0.05 * m.force_max());
  }
  EXPECT_GE(count, 2);
}

TEST(MaterialFile, PointsCsvErrorsNameTheLine) {
  const std::string path = ::testing::TempDir() + "/bad.points.csv";
  std::ofstream(path) << "# name = x\nstrain,force\n0.1,0.2\n0.2,abc\n";
  try {
    read_points_csv(path);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.item(), "line 4, force");
  }
  std::ofstream(path) << "eps,F\n0.1,0.2\n";
  EXPECT_THROW(read_points_csv(path), InputError);
  EXPECT_THROW(read_points_csv(path + ".missing"), InputError);
}

}  // namespace
}  // namespace tensegrity
