#include "solvers/ipopt/ipopt_solver.hpp"

#include <coin/IpIpoptApplication.hpp>
#include <coin/IpIpoptCalculatedQuantities.hpp>
#include <coin/IpIpoptData.hpp>
#include <coin/IpOrigIpoptNLP.hpp>
#include <coin/IpSolveStatistics.hpp>
#include <coin/IpTNLP.hpp>
#include <coin/IpTNLPAdapter.hpp>

#include <algorithm>
#include <charconv>
#include <limits>
#include <map>
#include <mutex>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "formulations/minimal_geometry_change_nlp.hpp"
#include "kernels/stress_qp.hpp"
#include "model/errors.hpp"
#include "model/verify.hpp"
#include "kernels/ipopt_run.hpp"
#include "solvers/option_reader.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {
namespace {

using Ipopt::Index;
using Ipopt::Number;

// Ipopt treats |bound| >= 1e19 as absent.
constexpr double kIpoptInfinity = 2e19;

double finite_or_ipopt_infinity(double v) {
  if (v == std::numeric_limits<double>::infinity()) return kIpoptInfinity;
  if (v == -std::numeric_limits<double>::infinity()) return -kIpoptInfinity;
  return v;
}

// The largest gravity load m_i |g| on a free node (0 without gravity): the
// contract's load scale when positive.
double max_free_node_weight(const Structure& s) {
  if (!s.has_gravity()) return 0.0;
  const Eigen::Matrix3Xd loads = s.gravity_loads();
  double worst = 0.0;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i]) worst = std::max(worst, loads.col(i).norm());
  return worst;
}

// Eq. 5 for Ipopt, made dimensionless:
//   y = ((q - q0) / L, sigma / F0),  rows f / F0 and c^T sigma / F0.
// With D = diag(L on q, F0 on sigma), z = z0 + D y, so
//   grad_y = D grad_z,  J_y = J_z D / F0,
//   Hess_y L(y; obj_factor, lambda_y) = D Hess_z L(z; obj_factor, lambda_y / F0) D.
// The per-triplet factors are computed once.
class Eq5Tnlp : public Ipopt::TNLP {
 public:
  Eq5Tnlp(MinimalGeometryChangeNlp& nlp, const Eigen::VectorXd& sigma0, TraceRecorder& recorder,
          double max_free_weight)
      : nlp_(nlp), recorder_(recorder), max_free_weight_(max_free_weight) {
    nq_ = nlp_.num_positions();
    m_ = nlp_.num_forces();
    n_ = nlp_.num_variables();
    ncon_ = nlp_.num_constraints();
    length_ = nlp_.length_scale();
    force_ = nlp_.force_scale().reference_force;
    q0_ = nlp_.reference_coordinates();
    variable_scale_ = Eigen::VectorXd(n_);
    variable_scale_.head(nq_).setConstant(length_);
    variable_scale_.tail(m_).setConstant(force_);

    nlp_.jacobian_structure(jac_rows_, jac_cols_);
    jac_factor_.resize(jac_rows_.size());
    for (std::size_t k = 0; k < jac_rows_.size(); ++k) jac_factor_[k] = variable_scale_[jac_cols_[k]] / force_;
    nlp_.hessian_structure(hess_rows_, hess_cols_);
    hess_factor_.resize(hess_rows_.size());
    for (std::size_t k = 0; k < hess_rows_.size(); ++k)
      hess_factor_[k] = variable_scale_[hess_rows_[k]] * variable_scale_[hess_cols_[k]];

    y0_ = Eigen::VectorXd::Zero(n_);
    y0_.tail(m_) = sigma0 / force_;
    z_ = nlp_.initial_point(sigma0);
    y_ = y0_;
    c_ = Eigen::VectorXd::Zero(ncon_);
    grad_ = Eigen::VectorXd::Zero(n_);
    lambda_ = Eigen::VectorXd::Zero(ncon_);
    z_final_ = z_;
  }

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac_g, Index& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = n_;
    m = ncon_;
    nnz_jac_g = static_cast<Index>(jac_rows_.size());
    nnz_h_lag = static_cast<Index>(hess_rows_.size());
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Index, Number* x_l, Number* x_u, Index, Number* g_l, Number* g_u) override {
    Eigen::VectorXd lower, upper;
    nlp_.variable_bounds(lower, upper);
    for (int i = 0; i < nq_; ++i) {
      x_l[i] = -kIpoptInfinity;
      x_u[i] = kIpoptInfinity;
    }
    for (int e = 0; e < m_; ++e) {
      x_l[nq_ + e] = finite_or_ipopt_infinity(lower[nq_ + e] / force_);
      x_u[nq_ + e] = finite_or_ipopt_infinity(upper[nq_ + e] / force_);
    }
    nlp_.constraint_bounds(lower, upper);
    for (int r = 0; r < ncon_; ++r) {
      g_l[r] = finite_or_ipopt_infinity(lower[r] / force_);  // -inf: the prestress cap row
      g_u[r] = upper[r] / force_;
    }
    return true;
  }

  bool get_starting_point(Index, bool init_x, Number* x, bool init_z, Number* z_L, Number* z_U, Index,
                          bool init_lambda, Number* lambda) override {
    if (init_x)
      for (int i = 0; i < n_; ++i) x[i] = y0_[i];
    // Only asked for under warm_start_init_point=yes: neutral multipliers.
    if (init_z)
      for (int i = 0; i < n_; ++i) z_L[i] = z_U[i] = 1.0;
    if (init_lambda)
      for (int r = 0; r < ncon_; ++r) lambda[r] = 0.0;
    return true;
  }

  bool eval_f(Index, const Number* x, bool, Number& obj_value) override {
    to_z(x);
    ++evaluations_;
    obj_value = nlp_.objective(z_);
    return std::isfinite(obj_value);
  }

  bool eval_grad_f(Index, const Number* x, bool, Number* grad_f) override {
    to_z(x);
    nlp_.gradient(z_, grad_);
    for (int i = 0; i < n_; ++i) grad_f[i] = grad_[i] * variable_scale_[i];
    return true;
  }

  bool eval_g(Index, const Number* x, bool, Index, Number* g) override {
    to_z(x);
    nlp_.constraints(z_, c_);
    for (int r = 0; r < ncon_; ++r) g[r] = c_[r] / force_;
    return c_.allFinite();
  }

  bool eval_jac_g(Index, const Number* x, bool, Index, Index nele_jac, Index* iRow, Index* jCol,
                  Number* values) override {
    if (values == nullptr) {
      for (Index k = 0; k < nele_jac; ++k) {
        iRow[k] = jac_rows_[k];
        jCol[k] = jac_cols_[k];
      }
      return true;
    }
    to_z(x);
    nlp_.jacobian_values(z_, values);
    for (Index k = 0; k < nele_jac; ++k) values[k] *= jac_factor_[k];
    return true;
  }

  bool eval_h(Index, const Number* x, bool, Number obj_factor, Index, const Number* lambda, bool,
              Index nele_hess, Index* iRow, Index* jCol, Number* values) override {
    if (values == nullptr) {
      for (Index k = 0; k < nele_hess; ++k) {
        iRow[k] = hess_rows_[k];
        jCol[k] = hess_cols_[k];
      }
      return true;
    }
    to_z(x);
    for (int r = 0; r < ncon_; ++r) lambda_[r] = lambda[r] / force_;
    nlp_.hessian_values(z_, obj_factor, lambda_, values);
    for (Index k = 0; k < nele_hess; ++k) values[k] *= hess_factor_[k];
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn, Index, const Number* x, const Number*, const Number*, Index,
                         const Number*, const Number*, Number, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    to_z(x);
    z_final_ = z_;
    has_final_point_ = true;
  }

  // One trace point per iteration. Ipopt 3.11 passes no x here: the current
  // iterate is read through the TNLPAdapter (not available in restoration).
  bool intermediate_callback(Ipopt::AlgorithmMode mode, Index iter, Number obj_value, Number inf_pr, Number,
                             Number, Number, Number, Number, Number, Index, const Ipopt::IpoptData* ip_data,
                             Ipopt::IpoptCalculatedQuantities* ip_cq) override {
    iterations_ = iter;
    TracePoint p;
    p.iteration = iter;
    p.evaluations = evaluations_;
    p.objective = obj_value;
    Ipopt::TNLPAdapter* adapter = nullptr;
    if (mode == Ipopt::RegularMode && ip_data != nullptr && ip_cq != nullptr) {
      auto* orig = dynamic_cast<Ipopt::OrigIpoptNLP*>(Ipopt::GetRawPtr(ip_cq->GetIpoptNLP()));
      if (orig != nullptr) adapter = dynamic_cast<Ipopt::TNLPAdapter*>(Ipopt::GetRawPtr(orig->nlp()));
    }
    if (adapter != nullptr) {
      adapter->ResortX(*ip_data->curr()->x(), y_.data());
      to_z(y_.data());
      p.residual = nlp_.max_node_residual(z_);
      const double load = max_free_weight_ > 0.0 ? max_free_weight_ : z_.tail(m_).cwiseAbs().maxCoeff();
      p.relative_residual = load > 0.0 ? p.residual / load : p.residual;
      p.geometry_change = (z_.head(nq_) - q0_).norm();
    } else {
      // Restoration phase: only Ipopt's own (scaled) infeasibility is known.
      p.residual = inf_pr * force_;
      p.relative_residual = inf_pr;
    }
    recorder_.record(p);
    if (recorder_.out_of_time()) {
      timed_out_ = true;
      return false;
    }
    return true;
  }

  bool has_final_point() const { return has_final_point_; }
  const Eigen::VectorXd& final_point() const { return z_final_; }
  bool timed_out() const { return timed_out_; }
  int iterations() const { return iterations_; }

 private:
  void to_z(const Number* y) {
    for (int i = 0; i < nq_; ++i) z_[i] = q0_[i] + length_ * y[i];
    for (int e = 0; e < m_; ++e) z_[nq_ + e] = force_ * y[nq_ + e];
  }

  MinimalGeometryChangeNlp& nlp_;
  TraceRecorder& recorder_;
  double max_free_weight_ = 0.0;
  int nq_ = 0, m_ = 0, n_ = 0, ncon_ = 0;
  double length_ = 1.0, force_ = 1.0;
  Eigen::VectorXd q0_, variable_scale_, y0_, y_, z_, c_, grad_, lambda_, z_final_;
  std::vector<int> jac_rows_, jac_cols_, hess_rows_, hess_cols_;
  std::vector<double> jac_factor_, hess_factor_;
  int evaluations_ = 0;
  int iterations_ = 0;
  bool timed_out_ = false;
  bool has_final_point_ = false;
};

// Ipopt's outcome in our terms, in one place. Success is only a candidate:
// the caller re-verifies before saying Converged.
Status status_from_ipopt(Ipopt::ApplicationReturnStatus code, bool timed_out, std::string& message) {
  switch (code) {
    case Ipopt::Solve_Succeeded: message = "Ipopt: optimal solution found"; return Status::Converged;
    case Ipopt::Solved_To_Acceptable_Level:
      message = "Ipopt: solved to acceptable level";
      return Status::Converged;
    case Ipopt::Maximum_Iterations_Exceeded:
      message = "Ipopt: maximum number of iterations exceeded";
      return Status::MaxIterations;
    case Ipopt::Maximum_CpuTime_Exceeded:
      message = "Ipopt: maximum CPU time exceeded";
      return Status::TimeLimit;
    case Ipopt::User_Requested_Stop:
      message = timed_out ? "Ipopt: wall-clock time limit reached" : "Ipopt: stopped by the callback";
      return timed_out ? Status::TimeLimit : Status::NumericalError;
    case Ipopt::Infeasible_Problem_Detected:
      // A point of local infeasibility is no proof that no tensegrity exists.
      message = "Ipopt: converged to a point of local infeasibility";
      return Status::Stalled;
    case Ipopt::Search_Direction_Becomes_Too_Small:
      message = "Ipopt: search direction becomes too small";
      return Status::NumericalError;
    case Ipopt::Diverging_Iterates: message = "Ipopt: iterates diverging"; return Status::NumericalError;
    case Ipopt::Restoration_Failed: message = "Ipopt: restoration phase failed"; return Status::NumericalError;
    case Ipopt::Error_In_Step_Computation:
      message = "Ipopt: error in step computation";
      return Status::NumericalError;
    case Ipopt::Invalid_Number_Detected:
      message = "Ipopt: invalid number in an evaluation";
      return Status::NumericalError;
    case Ipopt::Not_Enough_Degrees_Of_Freedom:
      message = "Ipopt: not enough degrees of freedom";
      return Status::NumericalError;
    default:
      message = "Ipopt: failed with return code " + std::to_string(static_cast<int>(code));
      return Status::NumericalError;
  }
}

// An application that never writes to stdout (which may carry the solution):
// with `verbose` its log goes to stderr.
Ipopt::SmartPtr<Ipopt::IpoptApplication> make_application(bool verbose) {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = new Ipopt::IpoptApplication(false, false);
  if (verbose) app->Jnlst()->AddFileJournal("console", "stderr", Ipopt::J_ITERSUMMARY);
  // An empty stream rather than the default "ipopt.opt" in the working directory.
  std::istringstream no_option_file;
  app->Initialize(no_option_file);
  return app;
}

// The valid values of a registered option, in the words of OptionReader.
std::string valid_values(const Ipopt::RegisteredOption& reg) {
  switch (reg.Type()) {
    case Ipopt::OT_Integer:
      return "an integer in [" + (reg.HasLower() ? std::to_string(reg.LowerInteger()) : std::string("-inf")) + ", " +
             (reg.HasUpper() ? std::to_string(reg.UpperInteger()) : std::string("inf")) + "]";
    case Ipopt::OT_Number: {
      ValueRange range;
      if (reg.HasLower()) range.low = reg.LowerNumber(), range.low_open = reg.LowerStrict();
      if (reg.HasUpper()) range.high = reg.UpperNumber(), range.high_open = reg.UpperStrict();
      return "a number in " + range.text();
    }
    default: {
      std::string names;
      for (const auto& entry : reg.GetValidStrings()) names += (names.empty() ? "" : ", ") + entry.value_;
      return names;
    }
  }
}

// Sets `key=value` in Ipopt's options, typed by Ipopt's own registry;
// OptionError when Ipopt does not know the key or rejects the value.
void set_native_option(Ipopt::IpoptApplication& app, const std::string& key, const std::string& value) {
  auto fail = [&](const std::string& reason) { throw OptionError("ipopt", key, value, reason); };
  Ipopt::SmartPtr<const Ipopt::RegisteredOption> reg = app.RegOptions()->GetOption(key);
  if (Ipopt::IsNull(reg)) fail("not an Ipopt option");
  bool accepted = false;
  switch (reg->Type()) {
    case Ipopt::OT_Integer: {
      int parsed = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), parsed);
      if (ec != std::errc() || end != value.data() + value.size())
        fail("not an integer (valid: " + valid_values(*reg) + ")");
      accepted = app.Options()->SetIntegerValue(key, parsed);
      break;
    }
    case Ipopt::OT_Number: {
      char* end = nullptr;
      const double parsed = std::strtod(value.c_str(), &end);
      if (value.empty() || end != value.c_str() + value.size() || !std::isfinite(parsed))
        fail("not a finite number (valid: " + valid_values(*reg) + ")");
      accepted = app.Options()->SetNumericValue(key, parsed);
      break;
    }
    default: accepted = app.Options()->SetStringValue(key, value); break;
  }
  if (!accepted) fail("out of range (valid: " + valid_values(*reg) + ")");
}

void apply_native_options(Ipopt::IpoptApplication& app, const OptionPairs& options) {
  for (const auto& [key, value] : options) set_native_option(app, key, value);
}

}  // namespace

IpoptOptions IpoptOptions::FromPairs(const OptionPairs& pairs) {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = make_application(false);
  apply_native_options(*app, pairs);
  IpoptOptions o;
  o.native = pairs;
  return o;
}

bool IpoptOptions::IsValid(std::string* why) const {
  try {
    FromPairs(native);
  } catch (const OptionError& e) {
    if (why) *why = e.what();
    return false;
  }
  return true;
}

SolveResult IpoptSolver::DoSolve(const PartProblem& part_problem, const IpoptOptions& ipopt_options) const {
  const Structure& part = part_problem.part;
  const SolveOptions& options = part_problem.options;
  TraceRecorder recorder(options.time_limit_s);
  SolveResult result;
  const ForceScale scale = make_force_scale(part, options.margin_fraction, options.prestress_factor);
  const double max_free_weight = max_free_node_weight(part);

  MinimalGeometryChangeNlp nlp(part, scale);
  Eigen::VectorXd sigma0;
  if (part_problem.initial_forces.size() == part.num_elements() && part_problem.initial_forces.allFinite()) {
    sigma0 = part_problem.initial_forces;  // the driver's stress QP at this geometry, same scale
  } else {
    StressQp qp(nlp.equilibrium(), scale);
    sigma0 = qp.solve().sigma;
    if (sigma0.size() != part.num_elements() || !sigma0.allFinite()) sigma0 = reference_forces(part, scale);
  }
  result.positions = part.positions;
  result.forces = sigma0;

  // Ipopt's constraint violation is the max-norm of f / F0; the contract asks
  // |f_i| <= tolerance * load scale, where the load scale is the largest
  // free-node weight with gravity and otherwise max |sigma| >= F0 (mean cable
  // force = F0). A tenth of that, for the three components of a node.
  const double load_over_force =
      max_free_weight > 0.0 ? std::min(1.0, max_free_weight / scale.reference_force) : 1.0;
  const double constraint_tolerance = 0.1 * options.tolerance * load_over_force / std::sqrt(3.0);

  // One Ipopt application at a time per process (solvers/ipopt_run.hpp): the
  // lock is taken before the application exists and released after it is
  // destroyed (its destructor ends the MUMPS instance).
  std::lock_guard<std::mutex> mumps_lock(mumps_mutex());
  Ipopt::SmartPtr<Eq5Tnlp> problem = new Eq5Tnlp(nlp, sigma0, recorder, max_free_weight);
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = make_application(options.verbose);
  Ipopt::OptionsList& o = *app->Options();
  o.SetIntegerValue("print_level", options.verbose ? 5 : 0);
  o.SetStringValue("sb", "yes");
  o.SetStringValue("linear_solver", "mumps");
  o.SetStringValue("hessian_approximation", "exact");
  o.SetStringValue("mu_strategy", "adaptive");
  // Tight: on scenes that need no change the barrier leaves a drift of order mu.
  o.SetNumericValue("tol", std::min(1e-12, options.tolerance));
  o.SetNumericValue("constr_viol_tol", constraint_tolerance);
  o.SetNumericValue("acceptable_tol", 1e-8);
  o.SetNumericValue("acceptable_constr_viol_tol", constraint_tolerance);
  o.SetIntegerValue("acceptable_iter", 5);
  // Ipopt relaxes bounds by this (y is O(1) near the margins) and projects the
  // result back onto them afterwards; that projection moves forces, so it must
  // stay below what the residual test can see.
  o.SetNumericValue("bound_relax_factor", 0.1 * constraint_tolerance);
  o.SetIntegerValue("max_iter", options.iteration_budget(kDefaultIterationBudget));
  // No max_cpu_time: Ipopt 3.11 measures the CPU time of the whole process, so
  // with solves on other threads it stops early (two busy threads: after half
  // the budget). The wall-clock limit is the intermediate callback's.
  apply_native_options(*app, ipopt_options.native);

  const Ipopt::ApplicationReturnStatus code = app->OptimizeTNLP(Ipopt::SmartPtr<Ipopt::TNLP>(GetRawPtr(problem)));
  result.native_code = static_cast<int>(code);
  result.status = status_from_ipopt(code, problem->timed_out(), result.message);
  result.stats.iterations = problem->iterations();
  if (Ipopt::IsValid(app->Statistics())) result.stats.iterations = app->Statistics()->IterationCount();

  if (problem->has_final_point() && problem->final_point().allFinite()) {
    result.positions = nlp.positions(problem->final_point());
    result.forces = nlp.forces(problem->final_point());
  }
  Verification v = verify(part, result.positions, result.forces, options.tolerance);
  if (result.status == Status::Converged && !v.ok && v.all_finite && v.wrong_signs == 0) {
    // Ipopt's scaled stopping test was met but not the contract's: one stress
    // solve at the final geometry, warm-started from Ipopt's forces.
    Equilibrium eq(part);
    eq.set_positions(result.positions);
    StressQp qp(eq, scale);
    const Eigen::VectorXd polished = qp.solve(result.forces).sigma;
    const Verification vp = verify(part, result.positions, polished, options.tolerance);
    if (vp.ok) {
      result.forces = polished;
      v = vp;
      result.message += " (forces polished by the stress QP)";
    }
  }
  if (!v.all_finite) {
    result.status = Status::NumericalError;
    result.positions = part.positions;
    result.forces = sigma0;
    v = verify(part, result.positions, result.forces, options.tolerance);
  }
  result.stats.seconds = recorder.seconds();
  result.stats.residual = v.residual;
  result.stats.relative_residual = v.relative_residual;
  result.stats.geometry_change = v.geometry_change;
  result.trace = std::move(recorder.trace());
  return result;
}

std::unique_ptr<Solver> make_ipopt_solver() { return std::make_unique<IpoptSolver>(); }

}  // namespace tensegrity
