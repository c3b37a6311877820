#include "design/naive_sweep.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "formulations/elastic_energy.hpp"
#include "design/rest_lengths.hpp"

namespace tensegrity {

namespace {

void measure(const ElasticModel& model, const ElasticEnergy& energy, const Eigen::Matrix3Xd& x, Settling& s) {
  s.size = model.length_scale;
  s.max_displacement = 0.0;
  s.max_displacement_node = -1;
  for (int i = 0; i < x.cols(); ++i) {
    const double d = (x.col(i) - model.reference.col(i)).norm();
    if (s.max_displacement_node < 0 || d > s.max_displacement) s.max_displacement = d, s.max_displacement_node = i;
  }
  s.relative_displacement = s.max_displacement / model.length_scale;
  const Eigen::VectorXd forces = energy.element_forces(x);
  s.slack_cables = 0;
  for (int e = 0; e < forces.size(); ++e)
    if (model.curve_of[e] >= 0 && forces[e] <= 0.0) ++s.slack_cables;
  s.cables_outside_range = energy.cables_outside_measured_range(x);
}

}  // namespace

Settling settle(const Design& design, const SettleOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const ElasticModel model = make_elastic_model(design);
  const ElasticEnergy energy(model);
  Settling s;
  if (options.method == SettleMethod::Relax) {
    const RelaxResult r = relax(energy, model.reference, {}, options.relax);
    s.status = r.status;
    s.message = r.message;
    measure(model, energy, r.positions, s);
  } else {
    bool held = false;
    for (bool f : model.structure.fixed) held = held || f;
    Simulator sim(model, model.structure.gravity, options.simulation);
    const int steps = static_cast<int>(std::ceil(options.duration / options.simulation.time_step - 1e-9));
    s.status = Status::Converged;
    s.message = "simulated " + std::to_string(steps) + " steps";
    if (!held && model.structure.gravity.squaredNorm() > 0.0) {
      // Free fall is not settling: report it the way relax does.
      s.status = Status::Infeasible;
      s.message = "gravity with no fixed node: the structure falls";
    }
    // A step whose Newton solve stops early keeps its last (descending)
    // iterate; later steps continue from there, and the count is reported.
    int unconverged = 0;
    for (int k = 0; k < steps && s.status == Status::Converged && sim.positions().allFinite(); ++k)
      if (!sim.step().converged) ++unconverged;
    if (unconverged > 0) {
      s.status = Status::MaxIterations;
      s.message = std::to_string(unconverged) + " of " + std::to_string(steps) + " steps ended before Newton converged";
    }
    if (!sim.positions().allFinite()) {
      s.status = Status::NumericalError;
      s.message = "non-finite positions";
    }
    s.kinetic_energy = sim.kinetic_energy();
    measure(model, energy, sim.positions(), s);
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

Design naive_design(const Design& designed, double fraction) {
  Design d = designed;
  const Eigen::Matrix3Xd& x = designed.solution.positions.cols() == designed.structure.num_nodes()
                                  ? designed.solution.positions
                                  : designed.structure.positions;
  // No material check here: out-of-range fractions are still simulated (the
  // energy continues the curve linearly) and flagged by the sweep.
  const RestLengthDesign rest = naive_rest_lengths(d.structure, x, fraction, {});
  d.solution.rest_lengths = rest.rest_lengths;
  d.strains = rest.strains;
  const auto materials = d.material_pointers();
  if (d.solution.forces.size() != d.structure.num_elements())
    d.solution.forces = Eigen::VectorXd::Zero(d.structure.num_elements());
  for (int e = 0; e < d.structure.num_elements(); ++e)
    if (d.structure.elements[e].kind == ElementKind::Cable && materials[e])
      d.solution.forces[e] = CableCurve(*materials[e]).force(rest.strains[e]);
  d.info = nlohmann::json::object();
  d.info["mode"] = "naive";
  d.info["naive_fraction"] = fraction;
  return d;
}

bool naive_fraction_in_material_range(const Design& designed, double fraction) {
  if (!(fraction > 0.0) || !std::isfinite(fraction)) return false;
  const double strain = 1.0 / fraction - 1.0;
  for (const auto& [name, m] : designed.materials)
    if (!m.in_range(strain)) return false;
  return true;
}

std::vector<double> fraction_grid(double from, double to, int n) {
  std::vector<double> f;
  if (n <= 0) return f;
  if (n == 1) return {from};
  for (int k = 0; k < n; ++k) f.push_back(from + (to - from) * k / (n - 1));
  return f;
}

std::vector<double> default_fraction_grid(const Design& designed, int n, double min_strain) {
  double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
  for (const auto& [name, m] : designed.materials) lo = std::max(lo, m.strain_min), hi = std::min(hi, m.strain_max);
  lo = std::max(lo, min_strain);
  if (!(lo < hi) || !std::isfinite(hi)) return {};
  // Largest strain = smallest fraction first.
  return fraction_grid(1.0 / (1.0 + hi), 1.0 / (1.0 + lo), n);
}

NaiveComparison naive_fraction_sweep(const Design& designed, std::span<const double> fractions,
                                     const SettleOptions& options, const std::function<void(int, int)>& progress) {
  NaiveComparison c;
  const int total = static_cast<int>(fractions.size()) + 1;
  c.designed = settle(designed, options);
  if (progress) progress(1, total);
  for (double f : fractions) {
    NaivePoint p;
    p.fraction = f;
    p.in_material_range = naive_fraction_in_material_range(designed, f);
    p.settling = settle(naive_design(designed, f), options);
    c.naive.push_back(p);
    if (progress) progress(static_cast<int>(c.naive.size()) + 1, total);
  }
  auto pick = [&](auto&& eligible) {
    int best = -1;
    for (int k = 0; k < static_cast<int>(c.naive.size()); ++k)
      if (eligible(c.naive[k]) &&
          (best < 0 || c.naive[k].settling.max_displacement < c.naive[best].settling.max_displacement))
        best = k;
    return best;
  };
  c.best = pick([](const NaivePoint& p) { return p.in_material_range && p.settling.status == Status::Converged; });
  if (c.best < 0) c.best = pick([](const NaivePoint& p) { return p.in_material_range; });
  if (c.best < 0) c.best = pick([](const NaivePoint&) { return true; });
  return c;
}

}  // namespace tensegrity
