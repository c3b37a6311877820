#pragma once
// Internal to solvers/ (never included by a public header): one Ipopt run of
// a TNLP under the process-wide MUMPS lock. MUMPS (sequential, as Debian
// builds it for Ipopt 3.11) keeps global state and is not thread-safe, so
// every Ipopt application of the process is created, run and destroyed while
// holding mumps_mutex().
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>

#include <functional>
#include <mutex>
#include <string>

namespace tensegrity {

std::mutex& mumps_mutex();

struct IpoptRun {
  Ipopt::ApplicationReturnStatus status = Ipopt::Internal_Error;
  int iterations = 0;
  std::string error;  // non-empty when Ipopt did not run (initialisation failed, an exception)
};

// Quiet by default (sb, print_level 0); `set_options` adds the caller's options.
IpoptRun run_ipopt(const Ipopt::SmartPtr<Ipopt::TNLP>& problem,
                   const std::function<void(Ipopt::OptionsList&)>& set_options);

}  // namespace tensegrity
