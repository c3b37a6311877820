#include <new>
#include <stdexcept>

#include "solvers/nlopt/nlopt_internal.hpp"

namespace tensegrity::nlopt_detail {

nlopt::result run_nlopt(nlopt::opt& opt, std::vector<double>& x) {
  double value = 0.0;
  try {
    return opt.optimize(x, value);
  } catch (const nlopt::roundoff_limited&) {
    return nlopt::ROUNDOFF_LIMITED;
  } catch (const nlopt::forced_stop&) {
    return nlopt::FORCED_STOP;
  } catch (const std::bad_alloc&) {
    return nlopt::OUT_OF_MEMORY;
  } catch (const std::invalid_argument&) {
    return nlopt::INVALID_ARGS;
  } catch (const std::runtime_error&) {
    return nlopt::FAILURE;
  }
}

const char* result_name(nlopt::result r) {
  switch (r) {
    case nlopt::FAILURE: return "FAILURE";
    case nlopt::INVALID_ARGS: return "INVALID_ARGS";
    case nlopt::OUT_OF_MEMORY: return "OUT_OF_MEMORY";
    case nlopt::ROUNDOFF_LIMITED: return "ROUNDOFF_LIMITED";
    case nlopt::FORCED_STOP: return "FORCED_STOP";
    case nlopt::SUCCESS: return "SUCCESS";
    case nlopt::STOPVAL_REACHED: return "STOPVAL_REACHED";
    case nlopt::FTOL_REACHED: return "FTOL_REACHED";
    case nlopt::XTOL_REACHED: return "XTOL_REACHED";
    case nlopt::MAXEVAL_REACHED: return "MAXEVAL_REACHED";
    case nlopt::MAXTIME_REACHED: return "MAXTIME_REACHED";
    default: return "UNKNOWN";
  }
}

Status status_from_nlopt(nlopt::result code, ForcedStop forced, const Verification& check) {
  if (check.ok) return Status::Converged;
  if (!check.all_finite || forced == ForcedStop::NonFinite) return Status::NumericalError;
  if (forced == ForcedStop::TimeLimit || code == nlopt::MAXTIME_REACHED) return Status::TimeLimit;
  switch (code) {
    case nlopt::MAXEVAL_REACHED:
      return Status::MaxIterations;
    case nlopt::SUCCESS:
    case nlopt::STOPVAL_REACHED:
    case nlopt::FTOL_REACHED:
    case nlopt::XTOL_REACHED:
      return Status::Stalled;  // NLopt stopped on its own tests without reaching equilibrium
    case nlopt::FORCED_STOP:
      return forced == ForcedStop::InnerConverged ? Status::MaxIterations
                                                  : Status::NumericalError;
    case nlopt::ROUNDOFF_LIMITED:
    case nlopt::FAILURE:
    case nlopt::INVALID_ARGS:
    case nlopt::OUT_OF_MEMORY:
    default:
      return Status::NumericalError;
  }
}

}  // namespace tensegrity::nlopt_detail
