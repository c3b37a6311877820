// The `tensegrity` program: subcommands registered from their own files.
#include <iostream>

#include "cli/commands.hpp"
#include "kernels/blas_threads.hpp"
#include "kernels/process_memory.hpp"
#include "reports/output.hpp"
#include "model/errors.hpp"
#include "model/known_keys.hpp"

int main(int argc, char** argv) {
  using namespace tensegrity;
  keep_freed_memory_in_process();
  end_blas_thread_pool();  // one BLAS thread per solve; its idle pool would spin on the other core
  CLI::App app{"tensegrity: form finding for tensegrity structures"};
  app.require_subcommand(1);
  cli::CommandRunner run;
  cli::register_solvers_command(app, run);
  cli::register_solve_command(app, run);
  cli::register_forces_command(app, run);
  cli::register_check_command(app, run);
  cli::register_generate_command(app, run);
  cli::register_build_command(app, run);
  cli::register_export_command(app, run);
  cli::register_render_command(app, run);
  cli::register_design_command(app, run);
  cli::register_fit_material_command(app, run);
  cli::register_simulate_command(app, run);
  cli::register_relax_command(app, run);
  cli::register_batch_command(app, run);
  cli::register_stress_test_command(app, run);
  cli::register_serve_command(app, run);
  cli::register_compare_command(app, run);
  cli::register_import_command(app, run);
  cli::register_suggest_link_command(app, run);
  cli::register_actuation_command(app, run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "tensegrity: usage: " << e.what() << "\n";
    return 2;
  }
  // Accepted input worth a word (unknown keys kept) gets one line per file.
  const ScopedInputWarningSink warnings([](const std::string& file, const std::string& message) {
    std::cerr << "tensegrity: " << file << ": warning: " << message << "\n";
  });
  try {
    return run ? run() : 2;
  } catch (const OptionError& e) {
    // The library names the option; the command line names the flag that gave it.
    std::cerr << reports::option_error_line(e) << "\n";
    return 2;
  } catch (const UnknownNameError& e) {
    const std::vector<CLI::App*> used = app.get_subcommands();
    std::cerr << reports::unknown_name_line(e, used.empty() ? "" : used.front()->get_name()) << "\n";
    return 2;
  } catch (const InputError& e) {
    std::cerr << "tensegrity: " << e.what() << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    std::cerr << "tensegrity: out of memory\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "tensegrity: error: " << e.what() << "\n";
    return 2;
  }
}
