// `tensegrity actuation` and `tensegrity suggest-link` end to end on the duck
// (data/characters/duck.character.json): the JSON numbers, the ranking rules,
// and bad input (exit 2, one line naming the file and the item, no file).
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "process_runner.hpp"

namespace tensegrity {
namespace {

const std::string kDuck = std::string(TENSEGRITY_SOURCE_DIR) + "/data/characters/duck.character.json";

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

void write_json(const std::string& path, const nlohmann::json& j) { std::ofstream(path) << j.dump(1); }

nlohmann::json head_poses(double down, double left) {
  return {{"format", "tensegrity-poses"},
          {"version", 1},
          {"poses",
           {{{"name", "down"}, {"targets", {{{"block", "head"}, {"by", {0.0, -down, 0.0}}}}}},
            {{"name", "left"}, {"targets", {{{"block", "head"}, {"by", {0.0, 0.0, left}}}}}}}}};
}

// The duck built, form-found and designed once, in one scratch folder.
class CliActuation : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::ScratchDir("cli-actuation");
    scene_ = dir_->file("duck.scene.json");
    solution_ = dir_->file("duck.solution.json");
    design_ = dir_->file("duck.design.json");
    ASSERT_EQ(dir_->run({"build", kDuck, "--out", scene_}).exit_status, 0);
    ASSERT_EQ(dir_->run({"solve", scene_, "--out", solution_, "--quiet"}).exit_status, 0);
    const testing::ProgramRun d = dir_->run({"design", scene_, "--out", design_, "--quiet"});
    ASSERT_EQ(d.exit_status, 0) << d.err;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  // Runs actuation with `poses`; the JSON file is `out` in the work folder.
  testing::ProgramRun actuation(const nlohmann::json& poses, const std::string& out, bool with_design = true) const {
    const std::string poses_file = dir_->file("poses.json");
    write_json(poses_file, poses);
    std::vector<std::string> args = {"actuation", scene_, "--solution", solution_, "--poses", poses_file,
                                     "--max-actuators", "3", "--json", dir_->file(out)};
    if (with_design) args.insert(args.end(), {"--design", design_});
    return dir_->run(args);
  }
  bool exists(const std::string& name) const { return std::ifstream(dir_->file(name)).good(); }

  static testing::ScratchDir* dir_;
  static std::string scene_, solution_, design_;
};

testing::ScratchDir* CliActuation::dir_ = nullptr;
std::string CliActuation::scene_, CliActuation::solution_, CliActuation::design_;

TEST_F(CliActuation, TwoHeadPosesAreReachedAndVerified) {
  const testing::ProgramRun r = actuation(head_poses(0.01, 0.01), "act.json");
  ASSERT_EQ(r.exit_status, 0) << r.err;
  const nlohmann::json j = read_json(dir_->file("act.json"));
  EXPECT_EQ(j["format"], "tensegrity-actuation");
  const auto& levels = j["levels"];
  ASSERT_EQ(levels.size(), 3u);
  const int num_elements = static_cast<int>(read_json(scene_)["elements"].size());
  std::vector<int> previous_elements;
  std::vector<double> previous_reached = {0.01, 0.01};
  for (std::size_t k = 0; k < levels.size(); ++k) {
    SCOPED_TRACE(k);
    const std::vector<int> elements = levels[k]["elements"];
    ASSERT_EQ(elements.size(), k + 1);
    EXPECT_EQ(levels[k]["actuators"], k + 1);
    // Each set extends the previous one by a new element.
    EXPECT_TRUE(std::equal(previous_elements.begin(), previous_elements.end(), elements.begin()));
    EXPECT_TRUE(elements.back() >= 0 && elements.back() < num_elements);
    EXPECT_EQ(std::count(elements.begin(), elements.end(), elements.back()), 1);
    previous_elements = elements;
    ASSERT_EQ(levels[k]["poses"].size(), 2u);
    for (int p = 0; p < 2; ++p) {
      const auto& pose = levels[k]["poses"][p];
      EXPECT_EQ(pose["name"], p == 0 ? "down" : "left");
      EXPECT_NEAR(pose["start_rms"].get<double>(), 0.01, 1e-12);  // every head node 1 cm from its target
      EXPECT_LT(pose["linear_rms"].get<double>(), pose["start_rms"].get<double>());
      const double reached = pose["reached_rms"];
      EXPECT_LT(reached, pose["start_rms"].get<double>());
      EXPECT_LE(reached, previous_reached[p] + 1e-12);  // a level starts where the previous one ended
      EXPECT_GE(pose["reached_max"].get<double>(), reached);
      EXPECT_GT(pose["steps_accepted"].get<int>(), 0);
      EXPECT_EQ(pose["rest_length_change"].size(), k + 1);
      previous_reached[p] = reached;
    }
  }
  // The first actuator is the neck-top link cable; with two, both poses are within 3 mm.
  EXPECT_NE(r.out.find("(link neck-top)"), std::string::npos) << r.out;
  for (int p = 0; p < 2; ++p) EXPECT_LT(levels[1]["poses"][p]["reached_rms"].get<double>(), 0.003);
}

TEST_F(CliActuation, LinearCordsAtTenPercentAreASaddleAndRefused) {
  const testing::ProgramRun r = actuation(head_poses(0.01, 0.01), "soft.json", false);
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_TRUE(testing::is_one_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(solution_ + ": positions: not a stable equilibrium"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("negative stiffness mode"), std::string::npos) << r.err;
  EXPECT_FALSE(exists("soft.json"));
}

TEST_F(CliActuation, UnknownBlockIsBadInput) {
  nlohmann::json poses = head_poses(0.01, 0.01);
  poses["poses"][1]["targets"][0]["block"] = "tail";
  const testing::ProgramRun r = actuation(poses, "bad.json");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_TRUE(testing::is_one_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(dir_->file("poses.json") + ": poses[1].targets[0].block: no free node of block 'tail'"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(exists("bad.json"));
}

TEST_F(CliActuation, FixedNodeIsBadInput) {
  const nlohmann::json scene = read_json(scene_);
  int fixed = -1;
  for (std::size_t i = 0; i < scene["nodes"].size() && fixed < 0; ++i)
    if (scene["nodes"][i].value("fixed", false)) fixed = static_cast<int>(i);
  ASSERT_GE(fixed, 0);
  nlohmann::json poses = head_poses(0.01, 0.01);
  poses["poses"][0]["targets"].push_back({{"node", fixed}, {"position", {0.0, 0.0, 0.0}}});
  const testing::ProgramRun r = actuation(poses, "bad.json");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_TRUE(testing::is_one_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(dir_->file("poses.json") + ": poses[0].targets[1].node: is a fixed node"), std::string::npos)
      << r.err;
  EXPECT_FALSE(exists("bad.json"));
}

TEST_F(CliActuation, MisspelledKeyIsBadInput) {
  nlohmann::json poses = head_poses(0.01, 0.01);
  poses["poses"][0]["targets"][0]["byy"] = poses["poses"][0]["targets"][0]["by"];
  poses["poses"][0]["targets"][0].erase("by");
  const testing::ProgramRun r = actuation(poses, "bad.json");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_TRUE(testing::is_one_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(dir_->file("poses.json") + ": poses[0].targets[0]: unknown key 'byy' (did you mean 'by'?)"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(exists("bad.json"));
}

// ---- suggest-link ---------------------------------------------------------------

std::vector<std::string> suggest_args(const testing::ScratchDir& dir, const std::string& a, bool stiff) {
  std::vector<std::string> args = {"suggest-link", kDuck, "--a", a, "--b", "neck"};
  if (stiff) {
    args.push_back("--stiff");
  } else {
    args.insert(args.end(), {"--axis", "0", "1", "0", "--range", "20"});
  }
  args.insert(args.end(), {"--faces", "2", "--cables", "2", "--json", dir.file("links.json")});
  return args;
}

void expect_consistent_stiffness(const nlohmann::json& c) {
  EXPECT_EQ(c["status"], "converged");
  EXPECT_TRUE(c["measured"].get<bool>());
  const std::vector<double> k = c["principal_stiffness"];
  ASSERT_EQ(k.size(), 3u);
  EXPECT_GT(k[0], 0.0);
  EXPECT_LE(k[0], k[1]);
  EXPECT_LE(k[1], k[2]);
  EXPECT_NEAR(c["anisotropy"].get<double>(), k[2] / k[0], 1e-9 * k[2] / k[0]);
}

// A hinge about y: 2 faces x 2 faces + 2 cables x 2 cables = 8 candidates,
// ranked by k_axis / k_perp ascending (the softest about the axis relative to
// the stiffest perpendicular).
TEST(CliSuggestLink, HingeCandidatesAreRankedByAxisOverPerpendicular) {
  const testing::ScratchDir dir("cli-suggest-link");
  const testing::ProgramRun r = dir.run(suggest_args(dir, "body", false));
  ASSERT_EQ(r.exit_status, 0) << r.err;
  const nlohmann::json j = read_json(dir.file("links.json"));
  EXPECT_EQ(j["format"], "tensegrity-link-suggestions");
  const auto& c = j["candidates"];
  ASSERT_EQ(c.size(), 8u);
  EXPECT_EQ(c[0]["type"], "face");
  double previous = 0.0;
  for (const auto& candidate : c) {
    expect_consistent_stiffness(candidate);
    const double ratio = candidate["about_axis"].get<double>() / candidate["perpendicular"].get<double>();
    EXPECT_NEAR(candidate["score"].get<double>(), ratio, 1e-12 * ratio);
    EXPECT_GE(ratio, previous);
    previous = ratio;
  }
}

// --stiff ranks by the smallest principal stiffness k_min, descending (score = -k_min);
// the axis plays no part.
TEST(CliSuggestLink, StiffRanksBySmallestPrincipalStiffnessDescending) {
  const testing::ScratchDir dir("cli-suggest-link");
  const testing::ProgramRun r = dir.run(suggest_args(dir, "body", true));
  ASSERT_EQ(r.exit_status, 0) << r.err;
  const auto c = read_json(dir.file("links.json"))["candidates"];
  ASSERT_EQ(c.size(), 8u);
  double previous = 1e300;
  for (const auto& candidate : c) {
    expect_consistent_stiffness(candidate);
    const double k_min = candidate["principal_stiffness"][0];
    EXPECT_DOUBLE_EQ(candidate["score"].get<double>(), -k_min);
    EXPECT_LE(k_min, previous);
    previous = k_min;
  }
}

TEST(CliSuggestLink, UnknownBlockIsBadInput) {
  const testing::ScratchDir dir("cli-suggest-link");
  const testing::ProgramRun r = dir.run(suggest_args(dir, "wing", false));
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_TRUE(testing::is_one_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(kDuck + ": blocks: no block with id 'wing'"), std::string::npos) << r.err;
  EXPECT_TRUE(dir.work_files().empty());
}

}  // namespace
}  // namespace tensegrity
