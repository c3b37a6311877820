// tensegrity fit-material POINTS.csv --out MATERIAL.json [--name N] [--diameter D]
//   [--linear-density RHO] [--description TEXT]
// Least-squares 5th-order force-strain fit; rejects a curve that is not
// strictly increasing over the measured strains (model/material.hpp).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "model/errors.hpp"
#include "model/material.hpp"

namespace tensegrity::cli {

void register_fit_material_command(CLI::App& app, CommandRunner& run) {
  struct Args {
    std::string points, out = "-", name, description;
    double diameter = std::nan(""), linear_density = std::nan("");
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("fit-material", "Fit a 5th-order force-strain curve to measured points");
  cmd->add_option("points", args->points, "CSV file with a 'strain,force' header (force in N)")->required();
  cmd->add_option("--out", args->out, "Material file to write (*.json), - for standard output");
  cmd->add_option("--name", args->name, "Material name (default: the file's '# name =' line, else its stem)");
  cmd->add_option("--description", args->description, "Free text");
  cmd->add_option("--diameter", args->diameter, "Cable diameter in m (default: the file's '# diameter =' line)");
  cmd->add_option("--linear-density", args->linear_density,
                  "Mass per length in kg/m (default: the file's '# linear_density =' line)");
  cmd->callback([args, &run] {
    run = [args] {
      const MeasuredPoints measured = read_points_csv(args->points);
      std::string name = args->name.empty() ? measured.name : args->name;
      if (name.empty()) {
        name = std::filesystem::path(args->points).filename().string();
        for (const char* suffix : {".csv", ".points"})
          if (name.size() > std::strlen(suffix) && name.ends_with(suffix)) name.resize(name.size() - std::strlen(suffix));
      }
      const double diameter = std::isnan(args->diameter) ? measured.diameter.value_or(std::nan("")) : args->diameter;
      const double density =
          std::isnan(args->linear_density) ? measured.linear_density.value_or(std::nan("")) : args->linear_density;
      if (!(diameter > 0.0) || !std::isfinite(diameter))
        throw InputError(args->points, "diameter", "missing or not > 0: give --diameter or a '# diameter =' line (m)");
      if (!(density >= 0.0) || !std::isfinite(density))
        throw InputError(args->points, "linear_density",
                         "missing or negative: give --linear-density or a '# linear_density =' line (kg/m)");
      MaterialFit fit = fit_material(measured.points, name, args->points);
      fit.material.description = args->description.empty() ? measured.description : args->description;
      fit.material.diameter = diameter;
      fit.material.linear_density = density;
      fit.material.fit["source"] = std::filesystem::path(args->points).filename().string();
      fit.material.fit["min_slope"] = fit.min_slope;
      write_material_file(fit.material, args->out);
      char line[512];
      std::snprintf(line, sizeof line,
                    "fit-material: %s: %d points, strain %.4g..%.4g, force %.4g..%.4g N, rms residual %.3g N, "
                    "max residual %.3g N, min slope %.3g N, monotone",
                    name.c_str(), fit.num_points, fit.material.strain_min, fit.material.strain_max,
                    fit.material.force_min(), fit.material.force_max(), fit.rms_residual, fit.max_residual,
                    fit.min_slope);
      std::cerr << line << "\n";
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
