#include "model/material.hpp"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <complex>
#include <limits>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "model/errors.hpp"
#include "model/format_keys.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"
#include "model/known_keys.hpp"
#include "model/scene_io.hpp"

namespace tensegrity {

using nlohmann::json;

namespace {

double horner(const std::vector<double>& a, double t) {
  double v = 0.0;
  for (auto it = a.rbegin(); it != a.rend(); ++it) v = v * t + *it;
  return v;
}

std::vector<double> derivative(const std::vector<double>& a) {
  std::vector<double> d;
  for (std::size_t k = 1; k < a.size(); ++k) d.push_back(static_cast<double>(k) * a[k]);
  return d;
}

std::vector<double> coefficients_of(const CableMaterial& m) {
  return std::vector<double>(m.coefficients.begin(), m.coefficients.end());
}

}  // namespace

double CableMaterial::force_unchecked(double eps) const { return horner(coefficients_of(*this), eps); }

double CableMaterial::slope_unchecked(double eps) const {
  double v = 0.0;
  for (int k = 5; k >= 1; --k) v = v * eps + k * coefficients[k];
  return v;
}

double CableMaterial::force(double eps) const {
  if (!std::isfinite(eps) || !in_range(eps))
    throw InputError(name, "strain " + message_number(eps),
                     "outside the measured range [" + message_number(strain_min) + ", " + message_number(strain_max) +
                         "] of the material (no extrapolation)");
  return force_unchecked(eps);
}

// A negligible leading coefficient (relative to the largest) would put huge
// spurious roots into the companion matrix; over a bounded strain range it
// changes nothing.
constexpr double kNegligibleLeadingCoefficient = 1e-14;
// Eigenvalues of the companion matrix lose a few digits: a root counts as real
// below this relative imaginary part, and Newton steps on the polynomial
// restore the lost digits.
constexpr double kRealRootImaginaryPart = 1e-7;
constexpr int kRootNewtonPolishSteps = 3;
// A polished root this close (relative) outside [lo, hi] is taken as the end.
constexpr double kRootRangeSlack = 1e-12;

std::vector<double> real_polynomial_roots(const std::vector<double>& a_in, double lo, double hi) {
  std::vector<double> a = a_in;
  double scale = 0.0;
  for (double v : a) scale = std::max(scale, std::abs(v));
  if (scale == 0.0) return {};
  while (!a.empty() && std::abs(a.back()) <= kNegligibleLeadingCoefficient * scale) a.pop_back();
  const int degree = static_cast<int>(a.size()) - 1;
  if (degree < 1) return {};
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(degree, degree);
  for (int i = 1; i < degree; ++i) companion(i, i - 1) = 1.0;
  for (int i = 0; i < degree; ++i) companion(i, degree - 1) = -a[i] / a[degree];
  Eigen::EigenSolver<Eigen::MatrixXd> eig(companion, false);
  std::vector<double> roots;
  if (eig.info() != Eigen::Success) return roots;
  const std::vector<double> da = derivative(a);
  for (int i = 0; i < degree; ++i) {
    const std::complex<double> z = eig.eigenvalues()[i];
    if (std::abs(z.imag()) > kRealRootImaginaryPart * (1.0 + std::abs(z.real()))) continue;
    double t = z.real();
    for (int it = 0; it < kRootNewtonPolishSteps; ++it) {
      const double d = horner(da, t);
      if (d == 0.0) break;
      t -= horner(a, t) / d;
    }
    const double slack = kRootRangeSlack * (1.0 + std::abs(hi - lo));
    if (t >= lo - slack && t <= hi + slack) roots.push_back(std::clamp(t, lo, hi));
  }
  std::sort(roots.begin(), roots.end());
  return roots;
}

std::optional<std::string> monotonicity_problem(const CableMaterial& m) {
  const double a = m.strain_min, b = m.strain_max;
  const std::vector<double> f = coefficients_of(m);
  const std::vector<double> df = derivative(f);
  const std::vector<double> ddf = derivative(df);
  for (double r : real_polynomial_roots(df, a, b))
    return "F'(eps) = 0 at eps = " + message_number(r) + ": the force-strain curve is not strictly increasing on [" +
           message_number(a) + ", " + message_number(b) + "]";
  std::vector<double> probes = real_polynomial_roots(ddf, a, b);
  constexpr int kGrid = 2000;
  for (int i = 0; i <= kGrid; ++i) probes.push_back(a + (b - a) * i / kGrid);
  double worst = std::numeric_limits<double>::infinity(), where = a;
  for (double t : probes) {
    const double s = horner(df, t);
    if (!(s >= worst)) worst = s, where = t;
  }
  if (!(worst > 0.0))
    return "F'(eps) = " + message_number(worst) + " N at eps = " + message_number(where) +
           ": the force-strain curve is not strictly increasing on [" + message_number(a) + ", " + message_number(b) + "]";
  return std::nullopt;
}

// ---- files ---------------------------------------------------------------------

const std::vector<std::string_view>& material_keys() {
  static const std::vector<std::string_view> keys = {"format",         "version",      "name",        "description",
                                                     "diameter",       "linear_density", "strain_range", "coefficients",
                                                     "fit"};
  return keys;
}

CableMaterial material_from_json(const json& j, const std::string& source) {
  KeyChecker keys(source);
  CableMaterial m = material_from_json(j, source, keys, "");
  keys.report();
  return m;
}

CableMaterial material_from_json(const json& j, const std::string& source, KeyChecker& keys,
                                 const std::string& item) {
  json_expect_header(j, "tensegrity-material", source);
  keys.check(j, material_keys(), item);
  auto need = [&](const char* key) -> const json& {
    if (!j.contains(key)) throw InputError(source, key, "missing");
    return j.at(key);
  };
  CableMaterial m;
  m.name = json_string(need("name"), source, "name");
  if (m.name.empty()) throw InputError(source, "name", "must not be empty");
  if (j.contains("description")) m.description = json_string(j.at("description"), source, "description");
  m.diameter = json_finite_number(need("diameter"), source, "diameter");
  if (!(m.diameter > 0.0)) throw InputError(source, "diameter", "must be > 0 (metres)");
  m.linear_density = json_finite_number(need("linear_density"), source, "linear_density");
  if (m.linear_density < 0.0) throw InputError(source, "linear_density", "must be >= 0 (kg/m)");
  const json& range = need("strain_range");
  if (!range.is_array() || range.size() != 2)
    throw InputError(source, "strain_range", "expected [strain_min, strain_max]");
  m.strain_min = json_finite_number(range[0], source, "strain_range[0]");
  m.strain_max = json_finite_number(range[1], source, "strain_range[1]");
  if (!(m.strain_min > -1.0)) throw InputError(source, "strain_range[0]", "must be > -1");
  if (!(m.strain_max > m.strain_min))
    throw InputError(source, "strain_range", "strain_max must be greater than strain_min");
  const json& c = need("coefficients");
  if (!c.is_array() || c.size() != 6)
    throw InputError(source, "coefficients", "expected six numbers c_0..c_5 of F(eps) = sum c_k eps^k (N)");
  for (int k = 0; k < 6; ++k)
    m.coefficients[k] = json_finite_number(c[k], source, "coefficients[" + std::to_string(k) + "]");
  if (j.contains("fit")) {
    if (!j.at("fit").is_object()) throw InputError(source, "fit", "expected an object");
    m.fit = j.at("fit");
  }
  if (const auto why = monotonicity_problem(m)) throw InputError(source, "coefficients", *why);
  for (auto it = j.begin(); it != j.end(); ++it)
    if (std::find(material_keys().begin(), material_keys().end(), it.key()) == material_keys().end())
      m.extra[it.key()] = *it;
  return m;
}

CableMaterial read_material_file(const std::string& path) { return material_from_json(read_json_file(path), path); }

json material_to_json(const CableMaterial& m) {
  json j = json::object();
  j["format"] = "tensegrity-material";
  j["version"] = 1;
  j["name"] = m.name;
  if (!m.description.empty()) j["description"] = m.description;
  j["diameter"] = m.diameter;
  j["linear_density"] = m.linear_density;
  j["strain_range"] = json::array({m.strain_min, m.strain_max});
  j["coefficients"] = json(std::vector<double>(m.coefficients.begin(), m.coefficients.end()));
  if (!m.fit.empty()) j["fit"] = m.fit;
  for (auto it = m.extra.begin(); it != m.extra.end(); ++it)
    if (!j.contains(it.key())) j[it.key()] = *it;
  return j;
}

void write_material_file(const CableMaterial& m, const std::string& path) {
  write_text_file_atomically(path, to_json_text(material_to_json(m)));
}

// ---- points --------------------------------------------------------------------

namespace {

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

double parse_number(const std::string& text, const std::string& path, const std::string& item) {
  const std::string t = trim(text);
  if (t.empty()) throw InputError(path, item, "empty field, expected a number");
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(t.c_str(), &end);
  if (end != t.c_str() + t.size()) throw InputError(path, item, "'" + t + "' is not a number");
  if (!std::isfinite(v) || errno == ERANGE) throw InputError(path, item, "'" + t + "' is not a finite number");
  return v;
}

}  // namespace

MeasuredPoints read_points_csv(const std::string& path) {
  // Read whole through the shared reader: it refuses directories, endless
  // devices and huge files, and does not hang on a FIFO.
  std::istringstream in(read_text_file(path));
  MeasuredPoints out;
  std::string line;
  int line_number = 0;
  bool header_seen = false;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string item = "line " + std::to_string(line_number);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string t = trim(line);
    if (t.empty()) continue;
    if (t[0] == '#') {
      const std::string body = trim(t.substr(1));
      const auto sep = body.find_first_of("=:");
      if (sep == std::string::npos) continue;
      const std::string key = lower(trim(body.substr(0, sep)));
      const std::string value = trim(body.substr(sep + 1));
      // A one-word key near a known one is a typo ("# diamter = 0.001" would
      // otherwise be a comment); other '#' lines are comments.
      static const std::vector<std::string_view> kPointKeys = {"name", "description", "diameter", "linear_density"};
      const bool one_word = !key.empty() && std::all_of(key.begin(), key.end(), [](unsigned char c) {
        return std::isalpha(c) || c == '_';
      });
      if (one_word) {
        const std::string intended = misspelled_key(key, kPointKeys);
        if (!intended.empty())
          throw InputError(path, item, "unknown key '" + key + "' (did you mean '" + intended + "'?)");
      }
      if (key == "name") out.name = value;
      else if (key == "description") out.description = value;
      else if (key == "diameter") out.diameter = parse_number(value, path, item + " (diameter)");
      else if (key == "linear_density") out.linear_density = parse_number(value, path, item + " (linear_density)");
      continue;
    }
    const auto comma = t.find(',');
    if (comma == std::string::npos || t.find(',', comma + 1) != std::string::npos)
      throw InputError(path, item, "expected two comma-separated fields: strain,force");
    if (!header_seen) {
      if (lower(trim(t.substr(0, comma))) != "strain" || lower(trim(t.substr(comma + 1))) != "force")
        throw InputError(path, item, "expected the header line 'strain,force'");
      header_seen = true;
      continue;
    }
    StrainForcePoint p;
    p.strain = parse_number(t.substr(0, comma), path, item + ", strain");
    p.force = parse_number(t.substr(comma + 1), path, item + ", force");
    out.points.push_back(p);
  }
  if (!header_seen) throw InputError(path, "", "no header line 'strain,force'");
  return out;
}

// ---- fitting -------------------------------------------------------------------

MaterialFit fit_material(const std::vector<StrainForcePoint>& points, const std::string& name,
                         const std::string& source) {
  constexpr int kOrder = 5;
  std::vector<double> strains;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::string item = "point " + std::to_string(i + 1);
    if (!std::isfinite(points[i].strain) || !std::isfinite(points[i].force))
      throw InputError(source, item, "not a finite number");
    if (!(points[i].strain > -1.0)) throw InputError(source, item, "strain must be > -1");
    strains.push_back(points[i].strain);
  }
  std::sort(strains.begin(), strains.end());
  const auto distinct = std::unique(strains.begin(), strains.end()) - strains.begin();
  if (distinct < kOrder + 1)
    throw InputError(source, "points",
                     "a 5th-order fit needs at least 6 distinct strains, got " + std::to_string(distinct));
  const double a = strains.front(), b = strains[distinct - 1];
  const double half = 0.5 * (b - a), mid = 0.5 * (a + b);

  // Chebyshev Vandermonde on t = (eps - mid) / half in [-1, 1].
  const int n = static_cast<int>(points.size());
  Eigen::MatrixXd V(n, kOrder + 1);
  Eigen::VectorXd f(n);
  for (int i = 0; i < n; ++i) {
    const double t = (points[i].strain - mid) / half;
    V(i, 0) = 1.0;
    V(i, 1) = t;
    for (int k = 2; k <= kOrder; ++k) V(i, k) = 2.0 * t * V(i, k - 1) - V(i, k - 2);
    f[i] = points[i].force;
  }
  const Eigen::VectorXd cheb = V.householderQr().solve(f);

  // Chebyshev -> monomials in t -> monomials in eps (t = alpha eps + beta).
  std::vector<std::vector<double>> T(kOrder + 1, std::vector<double>(kOrder + 1, 0.0));
  T[0][0] = 1.0;
  T[1][1] = 1.0;
  for (int k = 2; k <= kOrder; ++k)
    for (int j = 0; j <= kOrder; ++j) T[k][j] = (j > 0 ? 2.0 * T[k - 1][j - 1] : 0.0) - T[k - 2][j];
  std::vector<double> in_t(kOrder + 1, 0.0);
  for (int k = 0; k <= kOrder; ++k)
    for (int j = 0; j <= kOrder; ++j) in_t[j] += cheb[k] * T[k][j];
  const double alpha = 1.0 / half, beta = -mid / half;
  std::vector<double> in_eps(kOrder + 1, 0.0);
  std::vector<double> power{1.0};  // (alpha eps + beta)^j, ascending in eps
  for (int j = 0; j <= kOrder; ++j) {
    for (std::size_t k = 0; k < power.size(); ++k) in_eps[k] += in_t[j] * power[k];
    std::vector<double> next(power.size() + 1, 0.0);
    for (std::size_t k = 0; k < power.size(); ++k) {
      next[k] += beta * power[k];
      next[k + 1] += alpha * power[k];
    }
    power = std::move(next);
  }

  MaterialFit fit;
  fit.num_points = n;
  CableMaterial& m = fit.material;
  m.name = name;
  m.strain_min = a;
  m.strain_max = b;
  for (int k = 0; k <= kOrder; ++k) m.coefficients[k] = in_eps[k];
  double sum_sq = 0.0;
  for (const auto& p : points) {
    const double r = m.force_unchecked(p.strain) - p.force;
    sum_sq += r * r;
    fit.max_residual = std::max(fit.max_residual, std::abs(r));
  }
  fit.rms_residual = std::sqrt(sum_sq / n);
  fit.min_slope = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= 2000; ++i) fit.min_slope = std::min(fit.min_slope, m.slope_unchecked(a + (b - a) * i / 2000.0));
  if (const auto why = monotonicity_problem(m)) throw InputError(source, "fit", "rejected: " + *why);
  m.fit = json{{"points", n},
               {"rms_residual", fit.rms_residual},
               {"max_residual", fit.max_residual},
               {"basis", "chebyshev on the measured strain range, householder QR"}};
  return fit;
}

}  // namespace tensegrity
