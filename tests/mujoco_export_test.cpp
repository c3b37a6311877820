// The MJCF export of a designed character, loaded and simulated by MuJoCo:
// the tendons reproduce the designed rest lengths and forces, and the
// character holds its designed shape for 2 s under gravity.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <cmath>
#include <iostream>
#include <string>

#include "model/design.hpp"
#include "process_runner.hpp"

namespace tensegrity {
namespace {

using testing::ScratchDir;

const std::string kSource = TENSEGRITY_SOURCE_DIR;
constexpr double kSimulatedSeconds = 2.0;
// Largest node displacement after 2 s, as a fraction of the character's
// bounding-box diagonal: the soft constraints of MuJoCo give a little at the
// shared nodes and supports, so the shape is held to within 1 %, not exactly.
constexpr double kShapeTolerance = 0.01;

struct MujocoModel {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  ~MujocoModel() {
    if (d) mj_deleteData(d);
    if (m) mj_deleteModel(m);
  }
};

TEST(MujocoExport, DuckHoldsItsDesignedShape) {
  ScratchDir dir("mujoco");
  const std::string design_file = dir.file("duck.design.json"), xml = dir.file("duck.mjcf.xml");
  ASSERT_EQ(dir.run({"design", kSource + "/data/characters/duck.character.json", "--out", design_file}, 300).exit_status, 0);
  ASSERT_EQ(dir.run({"export", design_file, "--out", xml}).exit_status, 0);
  const Design design = read_design_file(design_file);
  const Structure& s = design.structure;

  char error[1000] = "";
  MujocoModel mj;
  mj.m = mj_loadXML(xml.c_str(), nullptr, error, sizeof error);
  ASSERT_NE(mj.m, nullptr) << error;
  mj.d = mj_makeData(mj.m);

  int cables = 0;
  for (const Element& e : s.elements) cables += e.kind == ElementKind::Cable;
  ASSERT_EQ(mj.m->ntendon, cables);
  mj_forward(mj.m, mj.d);
  // Tendon k: the k-th cable. Spring length = rest length, and the spring
  // force at the designed shape = the designed force.
  int k = 0;
  for (int e = 0; e < s.num_elements(); ++e) {
    if (s.elements[e].kind != ElementKind::Cable) continue;
    const double L = (*design.solution.rest_lengths)[e], F = design.solution.forces[e];
    EXPECT_NEAR(mj.m->tendon_lengthspring[k], L, 1e-8 * L);
    const double force = mj.m->tendon_stiffness[k] * (mj.d->ten_length[k] - mj.m->tendon_lengthspring[k]);
    EXPECT_NEAR(force, F, 1e-5 * std::abs(F) + 1e-9) << "cable " << e;
    ++k;
  }

  const Eigen::Matrix3Xd& x0 = design.solution.positions;
  auto site_position = [&](int node) {
    const int id = mj_name2id(mj.m, mjOBJ_SITE, ("n" + std::to_string(node)).c_str());
    EXPECT_GE(id, 0) << "node " << node;
    return Eigen::Vector3d(mj.d->site_xpos[3 * id], mj.d->site_xpos[3 * id + 1], mj.d->site_xpos[3 * id + 2]);
  };
  for (int i = 0; i < s.num_nodes(); ++i) EXPECT_LT((site_position(i) - x0.col(i)).norm(), 1e-9);

  // A step count, not the clock: MuJoCo resets an unstable simulation to time 0.
  const int steps = static_cast<int>(std::lround(kSimulatedSeconds / mj.m->opt.timestep));
  for (int k = 0; k < steps; ++k) mj_step(mj.m, mj.d);
  EXPECT_EQ(mj.d->warning[mjWARN_BADQACC].number, 0) << "MuJoCo found the simulation unstable";
  double largest_move = 0.0;
  for (int i = 0; i < s.num_nodes(); ++i) {
    const Eigen::Vector3d p = site_position(i);
    ASSERT_TRUE(p.allFinite());
    largest_move = std::max(largest_move, (p - x0.col(i)).norm());
  }
  const double diagonal = (x0.rowwise().maxCoeff() - x0.rowwise().minCoeff()).norm();
  std::cout << "largest node move after " << kSimulatedSeconds << " s: " << largest_move << " m ("
            << largest_move / diagonal << " of the diagonal " << diagonal << " m)\n";
  EXPECT_LT(largest_move, kShapeTolerance * diagonal);
}

}  // namespace
}  // namespace tensegrity
