#include "solvers/trace_csv.hpp"

#include <sstream>

#include "model/scene_io.hpp"

namespace tensegrity {

void write_trace_csv(const std::string& path, const std::vector<TracePoint>& trace) {
  std::ostringstream out;
  out.precision(17);
  out << "seconds,iteration,evaluations,residual,relative_residual,geometry_change,objective\n";
  for (const auto& p : trace)
    out << p.seconds << ',' << p.iteration << ',' << p.evaluations << ',' << p.residual << ','
        << p.relative_residual << ',' << p.geometry_change << ',' << p.objective << '\n';
  write_text_file_atomically(path, out.str());
}

}  // namespace tensegrity
