#include "solvers/alternating/alternating_solver.hpp"

#include <cmath>
#include <string>

#include "model/errors.hpp"
#include "solvers/option_reader.hpp"

// The options of both alternating variants (key=value pairs, ranges) and the
// backend details written to the solution file.
namespace tensegrity {
namespace {

// Largest window, inner-step count or SDC cycle length an option may ask for:
// beyond it a cycle outlasts any outer-iteration budget.
constexpr int kLargestStepCount = 10000;
constexpr int kLargestIterationCount = 1000000;

// The options both variants read.
void read_common_options(OptionReader& reader, AlternatingOptions& o) {
  o.epsilon_cvg = reader.number("epsilon_cvg", o.epsilon_cvg, ValueRange::non_negative());
  o.mu = reader.number("mu", o.mu, ValueRange::positive());
  o.margin = reader.number("margin", o.margin, ValueRange::left_open(0.0, 1.0));
}

}  // namespace

bool AlternatingOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (!(epsilon_cvg >= 0.0 && std::isfinite(epsilon_cvg))) return fail("epsilon_cvg must be in [0, inf)");
  if (!(mu > 0.0 && std::isfinite(mu))) return fail("mu must be in (0, inf)");
  if (!(margin >= 0.0 && margin < 1.0)) return fail("margin must be in [0, 1) (0: the shared sign margin)");
  if (!(gamma > 0.0 && std::isfinite(gamma))) return fail("gamma must be in (0, inf)");
  if (i_max < 1 || i_max > kLargestIterationCount) return fail("i_max must be in [1, 1000000]");
  if (crawl_window < 1 || crawl_window > kLargestStepCount) return fail("crawl_window must be in [1, 10000]");
  if (!(crawl_ratio > 0.0 && crawl_ratio <= 1.0)) return fail("crawl_ratio must be in (0, 1]");
  if (crawl_i_max < 1 || crawl_i_max > kLargestStepCount) return fail("crawl_i_max must be in [1, 10000]");
  if (sdc_cauchy_steps < 2 || sdc_cauchy_steps > kLargestStepCount) return fail("sdc_cauchy_steps must be in [2, 10000]");
  if (sdc_constant_steps < 1 || sdc_constant_steps > kLargestStepCount)
    return fail("sdc_constant_steps must be in [1, 10000]");
  if (!(max_step > 0.0 && std::isfinite(max_step))) return fail("max_step must be in (0, inf)");
  if (!(sigma_weight >= 0.0 && std::isfinite(sigma_weight))) return fail("sigma_weight must be in [0, inf)");
  if (!(lambda > 0.0 && std::isfinite(lambda))) return fail("lambda must be in (0, inf)");
  if (restarts < 0 || restarts > kMaxRestarts) return fail("restarts must be in [0, 5]");
  if (stall_window < 1 || stall_window > kLargestStepCount) return fail("stall_window must be in [1, 10000]");
  if (!(stall_ratio > 0.0 && stall_ratio <= 1.0)) return fail("stall_ratio must be in (0, 1]");
  if (!interior.IsValid())
    return fail("interior_force_weight must be > 0, interior_boundary_fraction in (0, 1), "
                "interior_anchor_until in [0, 1]");
  if (!interior_retry.IsValid()) return fail("interior_retry_iterations must be in [0, 1000000]");
  if (interior_retry_elements < 0) return fail("interior_retry_elements must be in [0, 1000000]");
  if (!interior_last_resort.IsValid()) return fail("interior_last_resort_iterations must be in [0, 1000000]");
  return true;
}

FaithfulAlternatingOptions FaithfulAlternatingOptions::FromPairs(const OptionPairs& pairs) {
  OptionReader reader(pairs, "alternating");
  FaithfulAlternatingOptions o;
  read_common_options(reader, o);
  o.gamma = reader.number("gamma", o.gamma, ValueRange::positive());
  o.i_max = reader.integer("i_max", o.i_max, 1, kLargestIterationCount);
  const std::string rule = reader.choice("step_length", "adaptive", {"adaptive", "cauchy", "sdc"});
  o.step_length = rule == "sdc"      ? FaithfulStepLength::Sdc
                  : rule == "cauchy" ? FaithfulStepLength::Cauchy
                                     : FaithfulStepLength::Adaptive;
  o.crawl_window = reader.integer("crawl_window", o.crawl_window, 1, kLargestStepCount);
  o.crawl_ratio = reader.number("crawl_ratio", o.crawl_ratio, ValueRange::left_open(0.0, 1.0));
  o.crawl_i_max = reader.integer("crawl_i_max", o.crawl_i_max, 1, kLargestStepCount);
  o.sdc_cauchy_steps = reader.integer("sdc_cauchy_steps", o.sdc_cauchy_steps, 2, kLargestStepCount);
  o.sdc_constant_steps = reader.integer("sdc_constant_steps", o.sdc_constant_steps, 1, kLargestStepCount);
  o.qp_proximal = reader.boolean("qp_proximal", o.qp_proximal);
  reader.reject_unknown();
  return o;
}

GaussNewtonAlternatingOptions GaussNewtonAlternatingOptions::FromPairs(const OptionPairs& pairs) {
  OptionReader reader(pairs, "alternating-gn");
  GaussNewtonAlternatingOptions o;
  read_common_options(reader, o);
  o.max_step = reader.number("max_step", o.max_step, ValueRange::positive());
  o.sigma_weight = reader.number("sigma_weight", o.sigma_weight, ValueRange::non_negative());
  o.qp_every_step = reader.boolean("qp_every_step", o.qp_every_step);
  o.qp_on_crossing = reader.boolean("qp_on_crossing", o.qp_on_crossing);
  o.move_bound_forces = reader.boolean("move_bound_forces", o.move_bound_forces);
  o.anchor = reader.boolean("anchor", o.anchor);
  o.restarts = reader.integer("restarts", o.restarts, 0, kMaxRestarts);
  o.stall_window = reader.integer("stall_window", o.stall_window, 1, kLargestStepCount);
  o.stall_ratio = reader.number("stall_ratio", o.stall_ratio, ValueRange::left_open(0.0, 1.0));
  o.lambda = reader.number("lambda", o.lambda, ValueRange::positive());
  o.interior.max_iterations = reader.integer("interior_iterations", o.interior.max_iterations, 0, kLargestIterationCount);
  o.interior.force_weight = reader.number("interior_force_weight", o.interior.force_weight, ValueRange::positive());
  o.interior.boundary_fraction =
      reader.number("interior_boundary_fraction", o.interior.boundary_fraction, ValueRange::open(0.0, 1.0));
  o.interior.anchor_until = reader.number("interior_anchor_until", o.interior.anchor_until, ValueRange::closed(0.0, 1.0));
  o.interior.margin_fraction = o.margin;
  o.interior_retry.max_iterations =
      reader.integer("interior_retry_iterations", o.interior_retry.max_iterations, 0, kLargestIterationCount);
  o.interior_retry.margin_fraction = o.margin;
  o.interior_retry_elements =
      reader.integer("interior_retry_elements", o.interior_retry_elements, 0, kLargestIterationCount);
  o.interior_last_resort.max_iterations = reader.integer(
      "interior_last_resort_iterations", o.interior_last_resort.max_iterations, 0, kLargestIterationCount);
  o.interior_last_resort.margin_fraction = o.margin;
  reader.reject_unknown();
  return o;
}

void AlternatingDetails::add_run(const AlternatingDetails& run, bool restart) {
  stress_solves += run.stress_solves;
  non_optimal_stress_solves += run.non_optimal_stress_solves;
  stalls += run.stalls;
  restarts += restart ? 1 : 0;
}

nlohmann::json AlternatingDetails::to_json() const {
  nlohmann::json j = {{"stress_solves", stress_solves},
                      {"non_optimal_stress_solves", non_optimal_stress_solves},
                      {"stalls", stalls},
                      {"held_at_prestress_cap", held_at_prestress_cap}};
  if (gauss_newton) {
    j["restarts"] = restarts;
    j["interior_iterations"] = interior_iterations;
  } else {
    j["sdc_from_iteration"] = sdc_from_iteration;
  }
  return j;
}

}  // namespace tensegrity
