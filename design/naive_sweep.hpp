#pragma once
// The fabrication end-to-end check (paper, section 5.1): a character
// built with the designed rest lengths settles at its designed shape under
// gravity, while the paper's baseline, every cable's rest length one constant
// fraction F of its deformed length, does not settle there for any F.
//
// "Settling" starts at rest at the designed shape, under the design's gravity,
// and ends either at the static equilibrium reached by energy descent (relax,
// solvers/simulator.hpp: Newton on the elastic energy) or after a damped
// implicit-Euler simulation of a given duration. The figure of merit is the
// largest node displacement from the designed shape (m), also relative to the
// size (the bounding-box diagonal of the designed shape).
//
// The naive designs share everything with the designed one except the cable
// rest lengths: same geometry, materials, masses and strut model (so the
// comparison isolates the rest lengths).
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "model/design.hpp"
#include "model/status.hpp"
#include "simulation/simulator.hpp"

namespace tensegrity {

enum class SettleMethod { Relax, Simulate };

struct SettleOptions {
  SettleMethod method = SettleMethod::Relax;
  // Naive designs can be far from equilibrium: a larger Newton budget than relax's default.
  RelaxOptions relax = [] {
    RelaxOptions o;
    o.max_iterations = 2000;
    return o;
  }();
  // Simulate: damped implicit Euler from rest for `duration` seconds.
  SimulationOptions simulation = [] {
    SimulationOptions o;
    o.time_step = 1.0 / 60.0;
    o.mass_damping = 2.0;  // 1/s: oscillations decay by e^-2 per second
    return o;
  }();
  double duration = 5.0;  // s
};

struct Settling {
  Status status = Status::NumericalError;
  std::string message;
  double max_displacement = 0.0;  // m, largest |x_i - designed x_i|
  int max_displacement_node = -1;
  double size = 0.0;              // m, bounding-box diagonal of the designed shape
  double relative_displacement = 0.0;  // max_displacement / size
  int slack_cables = 0;
  int cables_outside_range = 0;   // strain outside the measured range at the end
  double kinetic_energy = 0.0;    // J at the end (Simulate; 0 for Relax)
  double seconds = 0.0;
};

// Settles `design` (rest lengths fixed) under its own gravity.
Settling settle(const Design& design, const SettleOptions& options = {});

// The baseline made from a designed character: cable rest lengths fraction * l
// at the designed geometry (strain 1/fraction - 1); cable forces are what the
// material pulls with there (linear continuation outside its range, as the
// simulator does); struts and everything else as designed. `info` records
// the fraction.
Design naive_design(const Design& designed, double fraction);

// True when the naive strain 1/fraction - 1 lies in every used material's range.
bool naive_fraction_in_material_range(const Design& designed, double fraction);

// `n` fractions evenly spaced over [from, to] (n = 1: just `from`).
std::vector<double> fraction_grid(double from, double to, int n);
// The fractions whose strain lies in every material's measured range, with the
// strain capped below at `min_strain` (strain 0 means slack cables): n points.
std::vector<double> default_fraction_grid(const Design& designed, int n = 10, double min_strain = 0.05);

struct NaivePoint {
  double fraction = 0.0;
  bool in_material_range = false;  // a buildable baseline (`design --naive-fraction` accepts it)
  Settling settling;
};

struct NaiveComparison {
  Settling designed;
  std::vector<NaivePoint> naive;
  // Index into `naive` of the best baseline: smallest displacement among the
  // converged, in-range fractions (else among the in-range ones, else all);
  // -1 when the sweep is empty.
  int best = -1;
};

// Settles the design and the naive design for every fraction. `progress`
// (optional) is called after each settling with (done, total).
NaiveComparison naive_fraction_sweep(const Design& designed, std::span<const double> fractions,
                                     const SettleOptions& options = {},
                                     const std::function<void(int, int)>& progress = {});

}  // namespace tensegrity
