#pragma once
// The common ending of the alternating backends' part solves: scatter the
// free coordinates into full positions and fill the SolveResult, its stats
// measured by model/verify (the driver verifies the merged result again
// before it accepts a Converged claim).
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
