#pragma once
// Elastic cable materials (paper section 5.1, Fig. 7): the axial force of a
// cable as a 5th-order polynomial of its engineering strain,
//
//   F(eps) = sum_{k=0..5} c_k eps^k   (N),   eps = l / L - 1   (dimensionless),
//
// l the stretched length and L the rest length. A curve is only trusted on the
// strain range it was measured on, [strain_min, strain_max]: a strain outside
// it is an error, never an extrapolation. A usable material is strictly
// increasing there (F'(eps) > 0), so every force in [F(strain_min),
// F(strain_max)] has exactly one strain.
//
// Material files (data/materials/*.json, format "tensegrity-material",
// version 1) and measured points (*.points.csv: "strain,force" rows) are
// described in docs/FORMATS.md.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace tensegrity {

struct CableMaterial {
  std::string name;
  std::string description;
  double diameter = 0.0;          // m
  double linear_density = 0.0;    // kg/m (for cable masses)
  std::array<double, 6> coefficients{};  // c_0..c_5 of F(eps), N
  double strain_min = 0.0;        // measured range (dimensionless)
  double strain_max = 0.0;
  nlohmann::json fit = nlohmann::json::object();  // provenance and residuals, kept as is
  nlohmann::json extra = nlohmann::json::object();  // unknown keys of its file, written back as is

  bool in_range(double eps) const { return eps >= strain_min && eps <= strain_max; }
  // F(eps); throws InputError(name, "strain X", reason) outside the measured range.
  double force(double eps) const;
  // F(eps) and F'(eps) without the range check (root finders stay in range).
  double force_unchecked(double eps) const;
  double slope_unchecked(double eps) const;
  double force_min() const { return force_unchecked(strain_min); }
  double force_max() const { return force_unchecked(strain_max); }
};

// Why F is not strictly increasing on [strain_min, strain_max] (the smallest
// F' found and where), or nullopt when it is. Checks F' on a fine grid, at the
// ends, at every real root of F' in the range (where F' = 0) and at every real
// root of F'' (the local minima of F').
std::optional<std::string> monotonicity_problem(const CableMaterial& m);

// Real roots in [lo, hi] of sum_k a_k t^k (any degree, leading zeros allowed),
// from the eigenvalues of the companion matrix, sorted.
std::vector<double> real_polynomial_roots(const std::vector<double>& a, double lo, double hi);

// ---- files -------------------------------------------------------------------

// Validates every field (finite coefficients, strain_min < strain_max,
// strain_min > -1, positive diameter, non-negative density, monotone curve).
// A misspelled key is an InputError; other unknown keys are kept in `extra`
// and reported through the input-warning sink (model/known_keys.hpp).
CableMaterial material_from_json(const nlohmann::json& j, const std::string& source);
CableMaterial read_material_file(const std::string& path);
nlohmann::json material_to_json(const CableMaterial& m);
void write_material_file(const CableMaterial& m, const std::string& path);

// ---- fitting -----------------------------------------------------------------

struct StrainForcePoint {
  double strain = 0.0;  // dimensionless
  double force = 0.0;   // N
};

// Measured points with the metadata found in the file's "# key = value"
// comment lines (name, description, diameter, linear_density).
struct MeasuredPoints {
  std::vector<StrainForcePoint> points;
  std::string name, description;
  std::optional<double> diameter, linear_density;
};

// CSV with a header line "strain,force" (any case), one point per line; blank
// lines and lines starting with '#' are skipped ('#' lines may carry metadata).
MeasuredPoints read_points_csv(const std::string& path);

struct MaterialFit {
  CableMaterial material;   // coefficients, strain range = range of the points
  int num_points = 0;
  double rms_residual = 0.0;  // N, sqrt(mean (F(eps_i) - f_i)^2)
  double max_residual = 0.0;  // N, max |F(eps_i) - f_i|
  double min_slope = 0.0;     // N, min of F' over the range
};

// Least-squares 5th-order fit. The basis is Chebyshev polynomials of the strain
// mapped to [-1, 1] (a well-conditioned Vandermonde matrix, solved by Householder
// QR), converted to monomial coefficients of eps afterwards. Throws InputError
// (source, item, reason) for fewer than six distinct strains, non-finite
// values, strains <= -1, or a fit that is not strictly increasing over the
// measured range. The returned material's `fit` records the residuals.
MaterialFit fit_material(const std::vector<StrainForcePoint>& points, const std::string& name,
                         const std::string& source);

}  // namespace tensegrity
