// The one Ipopt adapter (kernels/ipopt_solve.hpp) on small problems with
// known optima and multipliers, its derivative check (kernels/sparse_nlp.hpp),
// and the one mapping of Ipopt's return codes to Status.
#include "kernels/ipopt_solve.hpp"

#include <coin/IpReturnCodes.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iterator>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "formulations/force_scale.hpp"
#include "formulations/minimal_geometry_change_nlp.hpp"
#include "kernels/blas_threads.hpp"
#include "kernels/sparse_nlp.hpp"
#include "scenes/suites.hpp"
#include "solvers/ipopt/dimensionless_eq5.hpp"

namespace tensegrity {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// minimize (x - 1)^2 + (y - 2)^2  s.t.  x + y = 1,  x >= x_min.
// Without the bound: x = 0, y = 1, lambda = 2 (grad f + lambda grad g = 0).
// With x_min = 0.5: x = y = 0.5, lambda = 3, z_L(x) = 2.
class LineNearestPoint final : public SparseNlp {
 public:
  explicit LineNearestPoint(double x_min = -kInf, double rhs = 1.0, double y_min = -kInf)
      : x_min_(x_min), y_min_(y_min), rhs_(rhs) {}
  int num_variables() const override { return 2; }
  int num_constraints() const override { return 1; }
  void variable_bounds(Vector lower, Vector upper) const override {
    lower << x_min_, y_min_;
    upper.setConstant(kInf);
  }
  void constraint_bounds(Vector lower, Vector upper) const override { lower[0] = upper[0] = rhs_; }
  void starting_point(Vector x) const override { x << 3.0, -1.0; }
  bool objective(const ConstVector& x, double& value) override {
    value = std::pow(x[0] - 1.0, 2) + std::pow(x[1] - 2.0, 2);
    return true;
  }
  bool gradient(const ConstVector& x, Vector g) override {
    g << 2.0 * (x[0] - 1.0), 2.0 * (x[1] - 2.0);
    return true;
  }
  bool constraints(const ConstVector& x, Vector g) override {
    g[0] = x[0] + x[1];
    return true;
  }
  bool jacobian_values(const ConstVector&, Vector values) override {
    values << 1.0, 1.0;
    return true;
  }
  bool hessian_values(const ConstVector&, double obj_factor, const ConstVector&, Vector values) override {
    values << 2.0 * obj_factor, 2.0 * obj_factor;
    return true;
  }
  SparsityPattern jacobian_structure() const override { return {{0, 0}, {0, 1}}; }
  SparsityPattern hessian_structure() const override { return {{0, 1}, {0, 1}}; }
  bool is_convex() const override { return convex; }
  void finalize(const NlpSolution& s) override {
    solution = s;
    ++finalized;
  }

  bool convex = true;
  NlpSolution solution;
  int finalized = 0;

 private:
  double x_min_, y_min_, rhs_;
};

// Hock-Schittkowski problem 71 (Ipopt's own example): nonlinear objective
// and constraints, a dense lower-triangular Hessian.
//   minimize x0 x3 (x0 + x1 + x2) + x2
//   s.t. x0 x1 x2 x3 >= 25,  x0^2 + x1^2 + x2^2 + x3^2 = 40,  1 <= x <= 5.
class Hs071 final : public SparseNlp {
 public:
  int num_variables() const override { return 4; }
  int num_constraints() const override { return 2; }
  void variable_bounds(Vector lower, Vector upper) const override {
    lower.setConstant(1.0);
    upper.setConstant(5.0);
  }
  void constraint_bounds(Vector lower, Vector upper) const override {
    lower << 25.0, 40.0;
    upper << kInf, 40.0;
  }
  void starting_point(Vector x) const override { x << 1.0, 5.0, 5.0, 1.0; }
  bool objective(const ConstVector& x, double& value) override {
    value = x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2];
    return true;
  }
  bool gradient(const ConstVector& x, Vector g) override {
    g << x[0] * x[3] + x[3] * (x[0] + x[1] + x[2]), x[0] * x[3], x[0] * x[3] + 1.0, x[0] * (x[0] + x[1] + x[2]);
    return true;
  }
  bool constraints(const ConstVector& x, Vector g) override {
    g << x[0] * x[1] * x[2] * x[3], x.squaredNorm();
    return true;
  }
  SparsityPattern jacobian_structure() const override {
    SparsityPattern p;
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 4; ++c) p.add(r, c);
    return p;
  }
  bool jacobian_values(const ConstVector& x, Vector v) override {
    v << x[1] * x[2] * x[3], x[0] * x[2] * x[3], x[0] * x[1] * x[3], x[0] * x[1] * x[2],  //
        2 * x[0], 2 * x[1], 2 * x[2], 2 * x[3];
    return true;
  }
  SparsityPattern hessian_structure() const override {
    SparsityPattern p;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c <= r; ++c) p.add(r, c);
    return p;
  }
  bool hessian_values(const ConstVector& x, double s, const ConstVector& l, Vector v) override {
    // Row-wise lower triangle: (0,0) (1,0) (1,1) (2,0) (2,1) (2,2) (3,0) (3,1) (3,2) (3,3).
    v << s * 2 * x[3] + 2 * l[1],                                                          //
        s * x[3] + l[0] * x[2] * x[3], 2 * l[1],                                            //
        s * x[3] + l[0] * x[1] * x[3], l[0] * x[0] * x[3], 2 * l[1],                        //
        s * (2 * x[0] + x[1] + x[2]) + l[0] * x[1] * x[2], s * x[0] + l[0] * x[0] * x[2],  //
        s * x[0] + l[0] * x[0] * x[1], 2 * l[1];
    return true;
  }
  void finalize(const NlpSolution& s) override { x = s.x; }
  Eigen::VectorXd x;
};

TEST(IpoptAdapter, EqualityConstrainedQuadraticHasTheKnownOptimumAndMultiplier) {
  LineNearestPoint problem;
  const IpoptSolveResult r = solve_with_ipopt(problem, IpoptSettings{});
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_EQ(r.return_code, Ipopt::Solve_Succeeded);
  EXPECT_TRUE(r.has_solution);
  EXPECT_EQ(problem.finalized, 1);
  EXPECT_GT(r.iterations, 0);
  EXPECT_NEAR(problem.solution.x[0], 0.0, 1e-8);
  EXPECT_NEAR(problem.solution.x[1], 1.0, 1e-8);
  EXPECT_NEAR(problem.solution.constraint_multipliers[0], 2.0, 1e-7);
}

TEST(IpoptAdapter, ActiveBoundGivesItsMultiplier) {
  LineNearestPoint problem(0.5);
  IpoptSettings settings;
  settings.set("tol", 1e-10);
  const IpoptSolveResult r = solve_with_ipopt(problem, settings);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_NEAR(problem.solution.x[0], 0.5, 1e-8);
  EXPECT_NEAR(problem.solution.x[1], 0.5, 1e-8);
  EXPECT_NEAR(problem.solution.constraint_multipliers[0], 3.0, 1e-6);
  EXPECT_NEAR(problem.solution.lower_bound_multipliers[0], 2.0, 1e-6);
  EXPECT_NEAR(problem.solution.lower_bound_multipliers[1], 0.0, 1e-6);  // y has no bound
  EXPECT_NEAR(problem.solution.upper_bound_multipliers[0], 0.0, 1e-6);
}

TEST(IpoptAdapter, Hs071ReachesItsPublishedOptimum) {
  Hs071 problem;
  IpoptSettings settings;
  settings.set("tol", 1e-10);
  const IpoptSolveResult r = solve_with_ipopt(problem, settings);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  const Eigen::Vector4d expected(1.0, 4.74299963, 3.82114998, 1.37940829);  // to the published 9 digits
  EXPECT_LT((problem.x - expected).cwiseAbs().maxCoeff(), 1e-6) << problem.x.transpose();
  double f = 0.0;
  problem.objective(problem.x, f);
  EXPECT_NEAR(f, 17.0140173, 1e-7);  // the published optimum, 9 digits
}

long threads_of_this_process() {
  const std::filesystem::directory_iterator tasks("/proc/self/task");
  return static_cast<long>(std::distance(begin(tasks), end(tasks)));
}

// The command line ends OpenBLAS's pool at its start (cli/main.cpp): OpenBLAS
// starts one thread per further core when it loads (none with
// OPENBLAS_NUM_THREADS=1 or on one core), and Ipopt's MUMPS then factors on
// the calling thread alone.
TEST(IpoptAdapter, AfterTheBlasPoolEndsOneThreadRemainsAndIpoptStillSolves) {
  const long threads_before = threads_of_this_process();
  end_blas_thread_pool();
  EXPECT_EQ(threads_of_this_process(), 1) << "threads before: " << threads_before;
  Hs071 problem;
  IpoptSettings settings;
  settings.set("tol", 1e-10);
  const IpoptSolveResult r = solve_with_ipopt(problem, settings);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  double f = 0.0;
  problem.objective(problem.x, f);
  EXPECT_NEAR(f, 17.0140173, 1e-7);
  EXPECT_EQ(threads_of_this_process(), 1);
}

TEST(IpoptAdapter, LaterOptionsWinAndAnUnknownOptionIsAnError) {
  Hs071 problem;
  IpoptSettings settings;
  settings.set("max_iter", 100);
  settings.set("max_iter", 2);
  IpoptSolveResult r = solve_with_ipopt(problem, settings);
  EXPECT_EQ(r.status, Status::MaxIterations) << r.message;
  EXPECT_EQ(r.return_code, Ipopt::Maximum_Iterations_Exceeded);
  EXPECT_EQ(r.iterations, 2);
  EXPECT_TRUE(r.has_solution);

  settings.set("no_such_option", 1.0);
  r = solve_with_ipopt(problem, settings);
  EXPECT_EQ(r.status, Status::NumericalError);
  EXPECT_FALSE(r.has_solution);
  EXPECT_NE(r.message.find("no_such_option"), std::string::npos) << r.message;
}

TEST(IpoptAdapter, TheCallbackSeesEveryIterateAndCanStopForTime) {
  LineNearestPoint problem;
  std::vector<std::pair<int, Eigen::VectorXd>> seen;
  IpoptSettings settings;
  settings.on_iteration = [&](const IpoptIteration& it) {
    if (it.x != nullptr) seen.emplace_back(it.iteration, *it.x);
    return it.iteration == 1 ? IterationControl::StopForTimeLimit : IterationControl::Continue;
  };
  const IpoptSolveResult r = solve_with_ipopt(problem, settings);
  EXPECT_EQ(r.status, Status::TimeLimit) << r.message;
  EXPECT_EQ(r.return_code, Ipopt::User_Requested_Stop);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].first, 0);
  // Iteration 0 is the starting point (3, -1), moved inside no bound.
  EXPECT_DOUBLE_EQ(seen[0].second[0], 3.0);
  EXPECT_DOUBLE_EQ(seen[0].second[1], -1.0);
  // A QP: one Newton step reaches the optimum.
  EXPECT_NEAR(seen[1].second[0], 0.0, 1e-8);
  EXPECT_NEAR(seen[1].second[1], 1.0, 1e-8);
}

TEST(IpoptAdapter, TheCallbackCanStopSatisfiedWithTheIterateItAccepted) {
  LineNearestPoint problem;
  IpoptSettings settings;
  settings.on_iteration = [&](const IpoptIteration& it) {
    return it.iteration == 1 ? IterationControl::StopSatisfied : IterationControl::Continue;
  };
  const IpoptSolveResult r = solve_with_ipopt(problem, settings);
  EXPECT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_EQ(r.return_code, Ipopt::User_Requested_Stop);
  EXPECT_EQ(r.iterations, 1);
  ASSERT_TRUE(r.has_solution);
  EXPECT_EQ(problem.finalized, 1);
  // A QP: one Newton step reached the optimum (0, 1), the point it stopped at.
  EXPECT_NEAR(problem.solution.x[0], 0.0, 1e-8);
  EXPECT_NEAR(problem.solution.x[1], 1.0, 1e-8);
}

TEST(IpoptAdapter, LocalInfeasibilityIsAProofOnlyForAConvexProblem) {
  // x + y = 1 with x, y >= 1: no feasible point.
  LineNearestPoint convex(1.0, 1.0, 1.0);
  const IpoptSolveResult proven = solve_with_ipopt(convex, IpoptSettings{});
  EXPECT_EQ(proven.return_code, Ipopt::Infeasible_Problem_Detected) << proven.message;
  EXPECT_EQ(proven.status, Status::Infeasible) << proven.message;

  LineNearestPoint unknown(1.0, 1.0, 1.0);
  unknown.convex = false;
  const IpoptSolveResult local = solve_with_ipopt(unknown, IpoptSettings{});
  EXPECT_EQ(local.return_code, Ipopt::Infeasible_Problem_Detected) << local.message;
  EXPECT_EQ(local.status, Status::Stalled) << local.message;
}

TEST(IpoptStatusMapping, EveryReturnCodeHasItsDocumentedStatus) {
  using S = Status;
  const std::vector<std::pair<Ipopt::ApplicationReturnStatus, Status>> table = {
      {Ipopt::Solve_Succeeded, S::Converged},
      {Ipopt::Solved_To_Acceptable_Level, S::Converged},
      {Ipopt::Infeasible_Problem_Detected, S::Stalled},  // not convex
      {Ipopt::Search_Direction_Becomes_Too_Small, S::NumericalError},
      {Ipopt::Diverging_Iterates, S::NumericalError},
      {Ipopt::User_Requested_Stop, S::NumericalError},  // not for the time limit
      {Ipopt::Feasible_Point_Found, S::NumericalError},
      {Ipopt::Maximum_Iterations_Exceeded, S::MaxIterations},
      {Ipopt::Restoration_Failed, S::NumericalError},
      {Ipopt::Error_In_Step_Computation, S::NumericalError},
      {Ipopt::Maximum_CpuTime_Exceeded, S::TimeLimit},
      {Ipopt::Not_Enough_Degrees_Of_Freedom, S::NumericalError},
      {Ipopt::Invalid_Problem_Definition, S::NumericalError},
      {Ipopt::Invalid_Option, S::NumericalError},
      {Ipopt::Invalid_Number_Detected, S::NumericalError},
      {Ipopt::Unrecoverable_Exception, S::NumericalError},
      {Ipopt::NonIpopt_Exception_Thrown, S::NumericalError},
      {Ipopt::Insufficient_Memory, S::NumericalError},
      {Ipopt::Internal_Error, S::NumericalError},
  };
  for (const auto& [code, status] : table) {
    const IpoptOutcome outcome = ipopt_outcome(code, false, false);
    EXPECT_EQ(outcome.status, status) << "code " << code << ": " << outcome.message;
    EXPECT_EQ(outcome.message.rfind("Ipopt: ", 0), 0u) << outcome.message;
  }
  // The two codes whose meaning depends on the circumstances.
  EXPECT_EQ(ipopt_outcome(Ipopt::Infeasible_Problem_Detected, true, false).status, S::Infeasible);
  EXPECT_EQ(ipopt_outcome(Ipopt::User_Requested_Stop, false, true).status, S::TimeLimit);
  EXPECT_EQ(ipopt_outcome(Ipopt::User_Requested_Stop, false, false, true).status, S::Converged);
  // The rest ignore them.
  for (const auto& [code, status] : table) {
    if (code != Ipopt::Infeasible_Problem_Detected && code != Ipopt::User_Requested_Stop) {
      EXPECT_EQ(ipopt_outcome(code, true, true).status, status) << "code " << code;
    }
  }
}

TEST(SparseNlpDerivativeCheck, AgreesWithAnalyticDerivativesAndCatchesAWrongOne) {
  Hs071 problem;
  const Eigen::Vector4d x(1.3, 4.1, 3.7, 1.6);
  const Eigen::Vector2d lambda(0.7, -1.9);
  const DerivativeCheck good = check_derivatives(problem, x, 0.8, lambda);
  EXPECT_TRUE(good.evaluated);
  EXPECT_LT(good.gradient_error, 1e-7);
  EXPECT_LT(good.jacobian_error, 1e-7);
  EXPECT_LT(good.hessian_error, 1e-7);

  // A Hessian that lists the upper triangle's entry (0,1) as well as (1,0)
  // counts it twice: the check must see that.
  class DoubledEntry final : public SparseNlp {
   public:
    explicit DoubledEntry(Hs071& base) : base_(base) {}
    int num_variables() const override { return 4; }
    int num_constraints() const override { return 2; }
    void variable_bounds(Vector l, Vector u) const override { base_.variable_bounds(l, u); }
    void constraint_bounds(Vector l, Vector u) const override { base_.constraint_bounds(l, u); }
    void starting_point(Vector x) const override { base_.starting_point(x); }
    bool objective(const ConstVector& x, double& f) override { return base_.objective(x, f); }
    bool gradient(const ConstVector& x, Vector g) override { return base_.gradient(x, g); }
    bool constraints(const ConstVector& x, Vector g) override { return base_.constraints(x, g); }
    bool jacobian_values(const ConstVector& x, Vector v) override { return base_.jacobian_values(x, v); }
    SparsityPattern jacobian_structure() const override { return base_.jacobian_structure(); }
    SparsityPattern hessian_structure() const override {
      SparsityPattern p = base_.hessian_structure();
      p.add(0, 1);
      return p;
    }
    bool hessian_values(const ConstVector& x, double s, const ConstVector& l, Vector v) override {
      Eigen::VectorXd lower(10);
      base_.hessian_values(x, s, l, lower);
      v << lower, lower[1];
      return true;
    }

   private:
    Hs071& base_;
  } doubled(problem);
  EXPECT_GT(check_derivatives(doubled, x, 0.8, lambda).hessian_error, 0.1);
}

// The backend's dimensionless Eq. 5: its per-entry scale factors of the
// Jacobian and the Hessian agree with differences of its own values.
TEST(SparseNlpDerivativeCheck, DimensionlessEq5HasConsistentScaledDerivatives) {
  for (const Structure& s : {scenes::perturbed(scenes::prism(5, -10.0), 0.05, 3u),
                             scenes::perturbed(scenes::prism(4, 10.0, true), 0.02, 22u)}) {
    const ForceScale scale = make_force_scale(s);
    MinimalGeometryChangeNlp nlp(s, scale);
    DimensionlessEq5 problem(nlp, reference_forces(s, scale));
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.05, 0.05);
    Eigen::VectorXd y(problem.num_variables());
    problem.starting_point(y);
    for (int i = 0; i < y.size(); ++i) y[i] += u(rng);
    Eigen::VectorXd lambda(problem.num_constraints());
    for (int r = 0; r < lambda.size(); ++r) lambda[r] = 20.0 * u(rng);
    const DerivativeCheck c = check_derivatives(problem, y, 0.9, lambda);
    EXPECT_TRUE(c.evaluated);
    EXPECT_LT(c.gradient_error, 1e-6);
    EXPECT_LT(c.jacobian_error, 1e-6);
    EXPECT_LT(c.hessian_error, 1e-5);
  }
}

}  // namespace
}  // namespace tensegrity
