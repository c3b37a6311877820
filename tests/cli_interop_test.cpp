// Research outputs and interop through the real program: `compare` on a
// perturbed prism (four verified rows, one start point for every trace),
// NTRT YAML import (an NTRT example, substructures and bonds) and the duck's
// round trip, export formats chosen by extension, OBJ colours and pictures.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/scene_io.hpp"
#include "model/solution.hpp"
#include "process_runner.hpp"
#include "scenes/suites.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

using testing::ScratchDir;

const std::string kSource = TENSEGRITY_SOURCE_DIR;
const std::string kNtrtPrism = kSource + "/tests/data/ntrt/3Prism.yaml";
const std::string kNtrtStack = kSource + "/tests/data/ntrt/stacked-prisms.yaml";

std::vector<std::vector<std::string>> csv_rows(const std::string& text) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::istringstream fs(line);
    std::string f;
    while (std::getline(fs, f, ',')) fields.push_back(f);
    rows.push_back(fields);
  }
  return rows;
}

std::set<std::tuple<int, int, int>> element_set(const Structure& s) {
  std::set<std::tuple<int, int, int>> out;
  for (const auto& e : s.elements)
    out.insert({e.kind == ElementKind::Strut ? 0 : 1, std::min(e.a, e.b), std::max(e.a, e.b)});
  return out;
}

TEST(CliCompare, PerturbedPrismGivesOneVerifiedRowPerBackendAndOneStartPoint) {
  ScratchDir dir("cli-compare");
  const std::string scene = dir.file("prism.scene.json"), out = dir.file("compare");
  write_scene_file(scenes::perturbed(scenes::prism(6), 0.05, 17u), scene);
  const auto r = dir.run({"compare", scene, "--out", out, "--repeat", "1"}, 600);
  ASSERT_EQ(r.exit_status, 0) << r.err << r.out;
  const auto rows = csv_rows(testing::read_text(out + "/compare.csv"));
  ASSERT_EQ(rows.size(), 1u + solver_names().size());  // header, one row per backend
  EXPECT_EQ(rows[0][0], "solver");
  std::set<std::string> solvers;
  for (std::size_t k = 1; k < rows.size(); ++k) {
    ASSERT_EQ(rows[k].size(), 8u);
    solvers.insert(rows[k][0]);
    EXPECT_EQ(rows[k][1], "converged") << rows[k][0];
    EXPECT_LE(std::stod(rows[k][4]), 1e-8) << rows[k][0];
    EXPECT_GT(std::stod(rows[k][5]), 0.0) << rows[k][0];  // the perturbed prism must move
    EXPECT_LE(std::stod(rows[k][6]), std::stod(rows[k][5]) + 1e-15);  // one node's move <= the norm
    EXPECT_EQ(rows[k][7], "yes");
  }
  EXPECT_EQ(solvers, (std::set<std::string>{"alternating", "alternating-gn", "eq5-newton", "ipopt", "nlopt"}));
  const auto json = nlohmann::json::parse(testing::read_text(out + "/compare.json"));
  EXPECT_EQ(json["rows"].size(), solvers.size());
  // Every backend's trace starts at the same point: 0 s, no geometry change,
  // the stress QP's relative residual at the input geometry.
  const auto trace = csv_rows(testing::read_text(out + "/compare-trace.csv"));
  std::map<std::string, std::vector<std::string>> first;
  for (std::size_t k = 1; k < trace.size(); ++k)
    if (!first.count(trace[k][0])) first[trace[k][0]] = trace[k];
  ASSERT_EQ(first.size(), solvers.size());
  const double start = std::stod(first["ipopt"][5]);
  EXPECT_GT(start, 1e-6);
  for (const auto& [solver, row] : first) {
    EXPECT_EQ(row[1], "0") << solver;
    EXPECT_EQ(row[2], "0") << solver;
    EXPECT_EQ(std::stod(row[5]), start) << solver;
    EXPECT_EQ(std::stod(row[6]), 0.0) << solver;
  }
  EXPECT_EQ(testing::read_text(out + "/compare.png").substr(1, 3), "PNG");
  const std::string svg = testing::read_text(out + "/compare.svg");
  EXPECT_NE(svg.find("<text"), std::string::npos);
  EXPECT_NE(svg.find("data-solver=\"nlopt\""), std::string::npos);
}

TEST(CliCompare, UnknownSolverIsBadInput) {
  ScratchDir dir("cli-compare");
  const std::string scene = dir.file("prism.scene.json");
  write_scene_file(scenes::prism(3), scene);
  const auto r = dir.run({"compare", scene, "--solvers", "alternating,nope", "--out", dir.file("c")});
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_TRUE(testing::is_one_line(r.err)) << r.err;
}

TEST(CliImport, NtrtPrismIsReadWithYUpAndFormFound) {
  ScratchDir dir("cli-import");
  const std::string scene = dir.file("prism.scene.json"), solution = dir.file("prism.solution.json");
  ASSERT_EQ(dir.run({"import", kNtrtPrism, "--out", scene}).exit_status, 0);
  const Structure s = read_scene_file(scene);
  ASSERT_EQ(s.num_nodes(), 6);
  int struts = 0;
  for (const auto& e : s.elements) struts += e.kind == ElementKind::Strut;
  EXPECT_EQ(struts, 3);  // the "prism_rod" builder is a tgRodInfo
  EXPECT_EQ(s.num_elements(), 12);
  // bottom3 at NTRT (0, 0, 8.66), y up: our (0, -8.66, 0); top1 (-5, 5, 0): our (-5, 0, 5).
  EXPECT_NEAR((s.positions.col(2) - Eigen::Vector3d(0, -8.66, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((s.positions.col(3) - Eigen::Vector3d(-5, 0, 5)).norm(), 0.0, 1e-12);
  EXPECT_EQ(s.node_extra[3]["name"], "top1");
  // Each element keeps its pair's tags.
  for (int e = 0; e < s.num_elements(); ++e) {
    ASSERT_TRUE(s.element_extra[e].contains("ntrt_tags")) << "element " << e;
    const std::string tags = s.element_extra[e]["ntrt_tags"];
    EXPECT_EQ(tags == "prism_rod segment", s.elements[e].kind == ElementKind::Strut) << tags;
  }
  // An untwisted prism is no tensegrity: form finding twists it.
  const auto r = dir.run({"solve", scene, "--solver", "ipopt", "--out", solution});
  ASSERT_EQ(r.exit_status, 0) << r.err;
  const Solution sol = read_solution_file(solution, s);
  EXPECT_EQ(sol.status, Status::Converged);
  EXPECT_GT(sol.stats.geometry_change, 0.1);
}

TEST(CliImport, NtrtSubstructuresRotationOffsetAndBonds) {
  ScratchDir dir("cli-import");
  const std::string scene = dir.file("stack.scene.json");
  ASSERT_EQ(dir.run({"import", kNtrtStack, "--out", scene, "--length-scale", "0.01"}).exit_status, 0);
  const Structure s = read_scene_file(scene);
  ASSERT_EQ(s.num_nodes(), 12);
  EXPECT_EQ(s.num_elements(), 2 * 12 + 3);
  EXPECT_EQ(s.node_extra[6]["name"], "upper.bottom1");
  // upper.bottom1: (-5, 0, 0) turned 60 degrees about the vertical through
  // (0, 0, 2.8867) is (-5, 0, 5.7735), then offset by (0, 6, 0); in metres, z up.
  EXPECT_NEAR((s.positions.col(6) - Eigen::Vector3d(-0.05, -0.057735, 0.06)).norm(), 0.0, 1e-6);
  // The bonds join lower.topK to upper.bottomK.
  const Element& bond = s.elements.back();
  EXPECT_EQ(s.node_extra[bond.a]["name"], "lower.top3");
  EXPECT_EQ(s.node_extra[bond.b]["name"], "upper.bottom3");
  EXPECT_EQ(bond.kind, ElementKind::Cable);
}

TEST(CliImport, NtrtRoundTripOfTheDuckKeepsNodesAndElements) {
  ScratchDir dir("cli-import");
  const std::string scene = dir.file("duck.scene.json"), yaml = dir.file("duck.yaml"), back = dir.file("back.scene.json");
  ASSERT_EQ(dir.run({"build", kSource + "/data/characters/duck.character.json", "--out", scene}).exit_status, 0);
  ASSERT_EQ(dir.run({"export", scene, "--out", yaml}).exit_status, 0);
  ASSERT_EQ(dir.run({"import", yaml, "--out", back}).exit_status, 0);
  const Structure a = read_scene_file(scene), b = read_scene_file(back);
  ASSERT_EQ(a.num_nodes(), b.num_nodes());
  EXPECT_LT((a.positions - b.positions).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(a.fixed, b.fixed);
  EXPECT_EQ(element_set(a), element_set(b));
}

TEST(CliExport, FormatFromTheExtension) {
  ScratchDir dir("cli-export");
  const std::string scene = dir.file("prism.scene.json");
  write_scene_file(scenes::prism(3), scene);
  ASSERT_EQ(dir.run({"export", scene, "--out", dir.file("p.obj")}).exit_status, 0);
  const std::string obj = testing::read_text(dir.file("p.obj"));
  EXPECT_EQ(obj.find("# vtk"), std::string::npos);
  EXPECT_NE(obj.find("\nl 1 2\n"), std::string::npos);
  EXPECT_EQ(csv_rows(testing::read_text(dir.file("p.obj.forces.csv"))).size(), 1u + 12u);
  ASSERT_EQ(dir.run({"export", scene, "--out", dir.file("p.vtk")}).exit_status, 0);
  EXPECT_NE(testing::read_text(dir.file("p.vtk")).find("SCALARS kind int 1"), std::string::npos);
  const auto bad = dir.run({"export", scene, "--out", dir.file("p.unknown")});
  EXPECT_EQ(bad.exit_status, 2);
  EXPECT_TRUE(testing::is_one_line(bad.err));
  const auto mjcf = dir.run({"export", scene, "--out", dir.file("p.mjcf.xml")});
  EXPECT_EQ(mjcf.exit_status, 2);  // MJCF needs a design
}

TEST(CliRender, SvgKeepsTextAndElementNames) {
  ScratchDir dir("cli-render");
  const std::string scene = dir.file("duck.scene.json"), svg = dir.file("duck.svg");
  ASSERT_EQ(dir.run({"build", kSource + "/data/characters/duck.character.json", "--out", scene}).exit_status, 0);
  ASSERT_EQ(dir.run({"render", scene, "--out", svg, "--colour-by", "block", "--labels"}).exit_status, 0);
  const std::string text = testing::read_text(svg);
  EXPECT_NE(text.find(">fixed node</text>"), std::string::npos);
  EXPECT_NE(text.find("data-element=\"body."), std::string::npos);
  EXPECT_NE(text.find(">scale</text>"), std::string::npos);
  EXPECT_EQ(text.find("<glyph"), std::string::npos);
}

// A broken frames file: one line naming the file, its line and frame and
// the place, exit status 2, no picture.
TEST(CliRender, BrokenFrameNamesItsLineAndFrame) {
  ScratchDir dir("cli-render");
  const std::string scene = kSource + "/data/reference/prism-3-gravity.scene.json", design = dir.file("p.design.json");
  const std::string frames = dir.file("frames.jsonl"), broken = dir.file("broken.jsonl"), png = dir.file("f.png");
  ASSERT_EQ(dir.run({"design", scene, "--out", design, "--quiet"}).exit_status, 0);
  ASSERT_EQ(dir.run({"simulate", design, "--steps", "3", "--out", frames, "--no-vtk"}).exit_status, 0);
  std::istringstream lines(testing::read_text(frames));
  std::string line, text;
  for (int k = 0; std::getline(lines, line); ++k) text += (k == 2 ? line.substr(0, 20) : line) + "\n";
  std::ofstream(broken) << text;
  const auto r = dir.run({"render", design, "--frames", broken, "--frame", "2", "--out", png});
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_TRUE(testing::is_one_line(r.err)) << r.err;
  EXPECT_EQ(r.err.rfind("tensegrity: " + broken + ": line 3 (frame 2), column 21: malformed JSON", 0), 0u) << r.err;
  EXPECT_FALSE(std::filesystem::exists(png));
}

}  // namespace
}  // namespace tensegrity

namespace tensegrity {
namespace {

TEST(CliCheck, JsonSummaryMatchesTheSolution) {
  testing::ScratchDir dir("cli-check");
  const std::string scene = dir.file("prism.scene.json"), solution = dir.file("prism.solution.json");
  write_scene_file(scenes::perturbed(scenes::prism(4), 0.05, 3u), scene);
  ASSERT_EQ(dir.run({"solve", scene, "--out", solution}).exit_status, 0);
  const auto r = dir.run({"check", scene, solution, "--json"});
  ASSERT_EQ(r.exit_status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const Solution sol = read_solution_file(solution, read_scene_file(scene));
  EXPECT_EQ(j.at("format"), "tensegrity-check");
  EXPECT_EQ(j.at("version"), 1);
  EXPECT_TRUE(j.at("verified").get<bool>());
  EXPECT_LE(j.at("relative_residual").get<double>(), 1e-8);
  EXPECT_NEAR(j.at("geometry_change").get<double>(), sol.stats.geometry_change, 1e-12);
  EXPECT_EQ(j.at("wrong_signs").get<int>(), 0);
}

}  // namespace
}  // namespace tensegrity
