#pragma once
// The common ending of the alternating backends' part solves: scatter the
// free coordinates into full positions, re-verify independently (model/verify)
// and fill the SolveResult. A `Converged` claim that the verification rejects
// becomes MaxIterations (NumericalError when something is not finite), with
// the verification's reasons in the message.
#include <Eigen/Core>
#include <string>

#include "formulations/free_nodes.hpp"
#include "solvers/solver.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {

SolveResult make_part_result(const Structure& part, const FreeNodeMap& map, const Eigen::VectorXd& q,
                             const Eigen::VectorXd& sigma, Status status, std::string message, double tolerance,
                             TraceRecorder& recorder);

}  // namespace tensegrity
