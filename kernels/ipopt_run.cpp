#include "kernels/ipopt_run.hpp"

#include <coin/IpSolveStatistics.hpp>

#include <exception>

namespace tensegrity {

std::mutex& mumps_mutex() {
  static std::mutex m;
  return m;
}

IpoptRun run_ipopt(const Ipopt::SmartPtr<Ipopt::TNLP>& problem,
                   const std::function<void(Ipopt::OptionsList&)>& set_options) {
  IpoptRun run;
  // Held until after the application is destroyed (its destructor ends the MUMPS instance).
  std::lock_guard<std::mutex> lock(mumps_mutex());
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetIntegerValue("print_level", 0);
  set_options(*app->Options());
  try {
    if (app->Initialize() != Ipopt::Solve_Succeeded) {
      run.error = "Ipopt failed to initialise";
      return run;
    }
    run.status = app->OptimizeTNLP(problem);
    if (Ipopt::IsValid(app->Statistics())) run.iterations = app->Statistics()->IterationCount();
  } catch (const std::exception& ex) {
    run.error = std::string("Ipopt: ") + ex.what();
  } catch (...) {
    run.error = "Ipopt threw an unknown exception";
  }
  return run;
}

}  // namespace tensegrity
