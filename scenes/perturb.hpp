#pragma once
// Seeded perturbations of a scene's geometry: the one place that moves nodes
// for tests, benchmarks and the stress-test families.
//
// Node noise adds to each chosen node a random vector of length at most
// `fraction * L`, where L is a length measured on the unperturbed scene (m).
// The noise shapes and length measures are named explicitly because stored
// benchmark scenes and test expectations are defined by them: the same
// parameters and seed always give the same bits.
#include <Eigen/Core>
#include <random>

#include "model/structure.hpp"

namespace tensegrity::scenes {

enum class NoiseShape {
  UniformBall,        // uniform in the unit ball (rejection sampling)
  CubeClippedToBall,  // uniform in the cube [-1, 1]^3, vectors longer than 1 scaled to length 1
  Cube,               // uniform in the cube [-1, 1]^3 (length up to sqrt 3)
  Gaussian,           // standard normal components (unbounded)
};

enum class LengthMeasure {
  LongestStrut,
  MeanStrut,
  MedianElement,
  FirstElement,
  OneMetre,  // L = 1 m: the fraction is a radius in metres
};

struct NodeNoise {
  double fraction = 0.01;  // of the length measure
  LengthMeasure length = LengthMeasure::MedianElement;
  NoiseShape shape = NoiseShape::UniformBall;
  bool move_fixed_nodes = false;
};

// The length L of `measure` on `s` (m); 1 when the scene has no such element.
double measure_length(const Structure& s, LengthMeasure measure);

// One random vector of `shape`, its components drawn in separate statements so
// that every compiler gives the same vector: x, y, z for the cube and the
// Gaussian, z, y, x for the ball shapes (the orders that define the stored
// benchmark and test scenes).
template <class Rng>
Eigen::Vector3d random_offset(NoiseShape shape, Rng& rng) {
  if (shape == NoiseShape::Gaussian || shape == NoiseShape::Cube) {
    std::normal_distribution<double> normal(0.0, 1.0);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::Vector3d d;
    for (int k = 0; k < 3; ++k) d[k] = shape == NoiseShape::Gaussian ? normal(rng) : uniform(rng);
    return d;
  }
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (;;) {
    const double z = u(rng);
    const double y = u(rng);
    const double x = u(rng);
    const Eigen::Vector3d d(x, y, z);
    switch (shape) {
      case NoiseShape::UniformBall:
        if (d.squaredNorm() <= 1.0) return d;
        break;
      case NoiseShape::CubeClippedToBall:
        return d.norm() > 1.0 ? Eigen::Vector3d(d.normalized()) : d;
      case NoiseShape::Cube:
      case NoiseShape::Gaussian:
        return d;  // drawn above
    }
  }
}

// Adds node noise to `s` in place, drawing from `rng` node by node in index order.
template <class Rng>
void add_node_noise(Structure& s, const NodeNoise& noise, Rng& rng) {
  const double radius = noise.fraction * measure_length(s, noise.length);
  for (int i = 0; i < s.num_nodes(); ++i) {
    if (s.fixed[i] && !noise.move_fixed_nodes) continue;
    s.positions.col(i) += radius * random_offset(noise.shape, rng);
  }
}

// A direction uniformly distributed on the unit sphere.
Eigen::Vector3d random_direction(std::mt19937_64& rng);

// A copy of `s` with node noise from a fresh std::mt19937 seeded with `seed`.
Structure with_node_noise(Structure s, const NodeNoise& noise, unsigned seed);

// Rotates the free nodes above the median height about the vertical axis
// through their centroid by `degrees`.
void twist_upper_half(Structure& s, double degrees);

// Moves one random free node to `distance` (m) from another random node.
void make_near_coincident(Structure& s, double distance, std::mt19937_64& rng);

// Turns one element sharing a node with another until the two make `angle` (rad).
void make_near_parallel(Structure& s, double angle, std::mt19937_64& rng);

// Fixes the three nodes lying furthest along `down` when no node is fixed, so
// that a gravity load has supports.
void ensure_supports(Structure& s, const Eigen::Vector3d& down);

}  // namespace tensegrity::scenes
