#include "kernels/ipopt_solve.hpp"

#include "kernels/blas_threads.hpp"

#include <coin/IpIpoptApplication.hpp>
#include <coin/IpIpoptCalculatedQuantities.hpp>
#include <coin/IpIpoptData.hpp>
#include <coin/IpOrigIpoptNLP.hpp>
#include <coin/IpSolveStatistics.hpp>
#include <coin/IpTNLP.hpp>
#include <coin/IpTNLPAdapter.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <mutex>
#include <sstream>

namespace tensegrity {
namespace {

using Ipopt::Index;
using Ipopt::Number;

// MUMPS's workspace as a percentage above its own estimate. With Ipopt's
// default, 1000, MUMPS allocates eleven times the estimate at every
// factorization, and on large scenes mapping and faulting in those pages
// takes a third of Ipopt's time and more (docs/BACKENDS.md); when the estimate
// falls short MUMPS says so, and Ipopt doubles the percentage and factorizes
// again.
constexpr int kMumpsWorkspacePercent = 100;

// Ipopt treats |bound| >= 1e19 (nlp_{lower,upper}_bound_inf) as absent.
constexpr double kIpoptInfinity = 2e19;

double to_ipopt_bound(double v) {
  if (std::isinf(v)) return v > 0 ? kIpoptInfinity : -kIpoptInfinity;
  return v;
}

std::mutex& mumps_mutex() {
  static std::mutex m;
  return m;
}

// Serves a SparseNlp to Ipopt: raw arrays in, Eigen views out.
class SparseNlpTnlp final : public Ipopt::TNLP {
 public:
  SparseNlpTnlp(SparseNlp& problem, const std::function<IterationControl(const IpoptIteration&)>& on_iteration)
      : problem_(problem),
        on_iteration_(on_iteration),
        n_(problem.num_variables()),
        m_(problem.num_constraints()),
        jacobian_(problem.jacobian_structure()),
        hessian_(problem.hessian_structure()),
        iterate_(Eigen::VectorXd::Zero(n_)) {}

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac_g, Index& nnz_h_lag, IndexStyleEnum& index_style) override {
    n = n_;
    m = m_;
    nnz_jac_g = jacobian_.size();
    nnz_h_lag = hessian_.size();
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Index, Number* x_l, Number* x_u, Index, Number* g_l, Number* g_u) override {
    Eigen::Map<Eigen::VectorXd> xl(x_l, n_), xu(x_u, n_), gl(g_l, m_), gu(g_u, m_);
    problem_.variable_bounds(xl, xu);
    problem_.constraint_bounds(gl, gu);
    xl = xl.unaryExpr(&to_ipopt_bound);
    xu = xu.unaryExpr(&to_ipopt_bound);
    gl = gl.unaryExpr(&to_ipopt_bound);
    gu = gu.unaryExpr(&to_ipopt_bound);
    return true;
  }

  bool get_starting_point(Index, bool init_x, Number* x, bool init_z, Number* z_L, Number* z_U, Index,
                          bool init_lambda, Number* lambda) override {
    if (init_x) problem_.starting_point(Eigen::Map<Eigen::VectorXd>(x, n_));
    // Only asked for under warm_start_init_point=yes: the problem's own, or
    // neutral multipliers.
    if (!init_z || !init_lambda) return !init_z && !init_lambda;  // Ipopt asks for both or neither
    Eigen::Map<Eigen::VectorXd> lower(z_L, n_), upper(z_U, n_), rows(lambda, m_);
    if (problem_.starting_multipliers(rows, lower, upper)) return true;
    lower.setOnes();
    upper.setOnes();
    rows.setZero();
    return true;
  }

  bool eval_f(Index, const Number* x, bool, Number& obj_value) override {
    return problem_.objective(point(x), obj_value);
  }

  bool eval_grad_f(Index, const Number* x, bool, Number* grad_f) override {
    return problem_.gradient(point(x), Eigen::Map<Eigen::VectorXd>(grad_f, n_));
  }

  bool eval_g(Index, const Number* x, bool, Index, Number* g) override {
    return problem_.constraints(point(x), Eigen::Map<Eigen::VectorXd>(g, m_));
  }

  bool eval_jac_g(Index, const Number* x, bool, Index, Index nele_jac, Index* iRow, Index* jCol,
                  Number* values) override {
    if (values == nullptr) return copy_structure(jacobian_, iRow, jCol);
    return problem_.jacobian_values(point(x), Eigen::Map<Eigen::VectorXd>(values, nele_jac));
  }

  bool eval_h(Index, const Number* x, bool, Number obj_factor, Index, const Number* lambda, bool, Index nele_hess,
              Index* iRow, Index* jCol, Number* values) override {
    if (values == nullptr) return copy_structure(hessian_, iRow, jCol);
    return problem_.hessian_values(point(x), obj_factor, Eigen::Map<const Eigen::VectorXd>(lambda, m_),
                                   Eigen::Map<Eigen::VectorXd>(values, nele_hess));
  }

  void finalize_solution(Ipopt::SolverReturn, Index, const Number* x, const Number* z_L, const Number* z_U, Index,
                         const Number*, const Number* lambda, Number, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    NlpSolution solution;
    solution.x = point(x);
    solution.constraint_multipliers = Eigen::Map<const Eigen::VectorXd>(lambda, m_);
    solution.lower_bound_multipliers = Eigen::Map<const Eigen::VectorXd>(z_L, n_);
    solution.upper_bound_multipliers = Eigen::Map<const Eigen::VectorXd>(z_U, n_);
    problem_.finalize(solution);
    has_solution_ = true;
  }

  // Ipopt 3.11 passes no x here: the current iterate is read through the
  // TNLPAdapter (not available in the restoration phase).
  bool intermediate_callback(Ipopt::AlgorithmMode mode, Index iter, Number obj_value, Number inf_pr, Number inf_du,
                             Number mu, Number, Number, Number, Number, Index, const Ipopt::IpoptData* ip_data,
                             Ipopt::IpoptCalculatedQuantities* ip_cq) override {
    last_iteration_ = iter;
    if (!on_iteration_) return true;
    IpoptIteration it;
    it.iteration = iter;
    it.objective = obj_value;
    it.primal_infeasibility = inf_pr;
    it.dual_infeasibility = inf_du;
    it.barrier_parameter = mu;
    Ipopt::TNLPAdapter* adapter = nullptr;
    if (mode == Ipopt::RegularMode && ip_data != nullptr && ip_cq != nullptr) {
      auto* orig = dynamic_cast<Ipopt::OrigIpoptNLP*>(Ipopt::GetRawPtr(ip_cq->GetIpoptNLP()));
      if (orig != nullptr) adapter = dynamic_cast<Ipopt::TNLPAdapter*>(Ipopt::GetRawPtr(orig->nlp()));
    }
    if (adapter != nullptr) {
      adapter->ResortX(*ip_data->curr()->x(), iterate_.data());
      it.x = &iterate_;
    }
    switch (on_iteration_(it)) {
      case IterationControl::Continue: return true;
      case IterationControl::StopForTimeLimit: stopped_for_time_limit_ = true; return false;
      case IterationControl::StopSatisfied: stopped_satisfied_ = true; return false;
    }
    return true;
  }

  bool has_solution() const { return has_solution_; }
  bool stopped_for_time_limit() const { return stopped_for_time_limit_; }
  bool stopped_satisfied() const { return stopped_satisfied_; }
  int last_iteration() const { return last_iteration_; }

 private:
  Eigen::Map<const Eigen::VectorXd> point(const Number* x) const { return {x, n_}; }

  static bool copy_structure(const SparsityPattern& pattern, Index* iRow, Index* jCol) {
    std::copy(pattern.rows.begin(), pattern.rows.end(), iRow);
    std::copy(pattern.cols.begin(), pattern.cols.end(), jCol);
    return true;
  }

  SparseNlp& problem_;
  const std::function<IterationControl(const IpoptIteration&)>& on_iteration_;
  int n_ = 0, m_ = 0;
  SparsityPattern jacobian_, hessian_;
  Eigen::VectorXd iterate_;
  int last_iteration_ = 0;
  bool has_solution_ = false;
  bool stopped_for_time_limit_ = false;
  bool stopped_satisfied_ = false;
};

// An application that never writes to stdout and reads no option file: with
// `verbose` its log goes to stderr.
Ipopt::SmartPtr<Ipopt::IpoptApplication> make_application(bool verbose, std::string& error) {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = new Ipopt::IpoptApplication(false, false);
  if (verbose) app->Jnlst()->AddFileJournal("console", "stderr", Ipopt::J_ITERSUMMARY);
  // An empty stream rather than the default "ipopt.opt" in the working directory.
  std::istringstream no_option_file;
  if (app->Initialize(no_option_file) != Ipopt::Solve_Succeeded) error = "Ipopt failed to initialise";
  return app;
}

bool set_option(Ipopt::OptionsList& options, const IpoptOption& option) {
  if (const auto* text = std::get_if<std::string>(&option.value)) return options.SetStringValue(option.name, *text);
  if (const auto* integer = std::get_if<int>(&option.value)) return options.SetIntegerValue(option.name, *integer);
  return options.SetNumericValue(option.name, std::get<double>(option.value));
}

}  // namespace

IpoptOutcome ipopt_outcome(int return_code, bool convex_problem, bool stopped_for_time_limit,
                           bool stopped_satisfied) {
  switch (static_cast<Ipopt::ApplicationReturnStatus>(return_code)) {
    case Ipopt::Solve_Succeeded: return {Status::Converged, "Ipopt: optimal solution found"};
    case Ipopt::Solved_To_Acceptable_Level: return {Status::Converged, "Ipopt: solved to acceptable level"};
    case Ipopt::Infeasible_Problem_Detected:
      if (convex_problem) return {Status::Infeasible, "Ipopt: the (convex) problem is infeasible"};
      return {Status::Stalled, "Ipopt: converged to a point of local infeasibility"};
    case Ipopt::Maximum_Iterations_Exceeded:
      return {Status::MaxIterations, "Ipopt: maximum number of iterations exceeded"};
    case Ipopt::Maximum_CpuTime_Exceeded: return {Status::TimeLimit, "Ipopt: maximum CPU time exceeded"};
    case Ipopt::User_Requested_Stop:
      if (stopped_for_time_limit) return {Status::TimeLimit, "Ipopt: wall-clock time limit reached"};
      if (stopped_satisfied) return {Status::Converged, "Ipopt: stopped at an iterate that passes the caller's test"};
      return {Status::NumericalError, "Ipopt: stopped by the callback"};
    case Ipopt::Search_Direction_Becomes_Too_Small:
      return {Status::NumericalError, "Ipopt: search direction becomes too small"};
    case Ipopt::Diverging_Iterates: return {Status::NumericalError, "Ipopt: iterates diverging"};
    case Ipopt::Restoration_Failed: return {Status::NumericalError, "Ipopt: restoration phase failed"};
    case Ipopt::Error_In_Step_Computation: return {Status::NumericalError, "Ipopt: error in step computation"};
    case Ipopt::Invalid_Number_Detected: return {Status::NumericalError, "Ipopt: invalid number in an evaluation"};
    case Ipopt::Not_Enough_Degrees_Of_Freedom:
      return {Status::NumericalError, "Ipopt: not enough degrees of freedom"};
    default:
      return {Status::NumericalError, "Ipopt: failed with return code " + std::to_string(return_code)};
  }
}

IpoptSolveResult solve_with_ipopt(SparseNlp& problem, const IpoptSettings& settings) {
  IpoptSolveResult result;
  // Held until after the application is destroyed (its destructor ends the MUMPS instance).
  std::lock_guard<std::mutex> lock(mumps_mutex());
  use_one_blas_thread();  // reproducible factorizations (kernels/blas_threads.hpp)
  try {
    Ipopt::SmartPtr<Ipopt::IpoptApplication> app = make_application(settings.verbose, result.message);
    if (!result.message.empty()) return result;
    Ipopt::OptionsList& options = *app->Options();
    options.SetStringValue("sb", "yes");
    options.SetIntegerValue("print_level", settings.verbose ? 5 : 0);
    options.SetIntegerValue("mumps_mem_percent", kMumpsWorkspacePercent);
    for (const IpoptOption& option : settings.options)
      if (!set_option(options, option)) {
        result.message = "Ipopt rejected the option " + option.name;
        return result;
      }
    Ipopt::SmartPtr<SparseNlpTnlp> tnlp = new SparseNlpTnlp(problem, settings.on_iteration);
    const Ipopt::ApplicationReturnStatus code = app->OptimizeTNLP(Ipopt::SmartPtr<Ipopt::TNLP>(GetRawPtr(tnlp)));
    result.return_code = static_cast<int>(code);
    IpoptOutcome outcome = ipopt_outcome(result.return_code, problem.is_convex(), tnlp->stopped_for_time_limit(),
                                         tnlp->stopped_satisfied());
    result.status = outcome.status;
    result.message = std::move(outcome.message);
    result.iterations = tnlp->last_iteration();
    if (Ipopt::IsValid(app->Statistics())) result.iterations = app->Statistics()->IterationCount();
    result.has_solution = tnlp->has_solution();
    if (result.status == Status::Converged && !result.has_solution) {
      result.status = Status::NumericalError;
      result.message = "Ipopt reported success without a final point";
    }
  } catch (const std::exception& ex) {
    result.message = std::string("Ipopt: ") + ex.what();
  } catch (...) {
    result.message = "Ipopt threw an unknown exception";
  }
  return result;
}

}  // namespace tensegrity
