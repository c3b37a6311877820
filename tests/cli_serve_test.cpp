// `tensegrity serve`'s POST /api/suggest-link: the ranking equals the one
// `tensegrity suggest-link` prints and writes for the same character and
// options, and a bad request gets 400 with the command's one line (its
// "command line" named "request") while the server keeps answering.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "process_runner.hpp"

// Last: it includes <resolv.h>, whose macros would break Eigen's headers.
#include <httplib.h>

namespace tensegrity {
namespace {

using nlohmann::json;
using testing::read_text;
using testing::ScratchDir;
using testing::start_program;
using testing::wait_program;

const std::string kDuck = std::string(TENSEGRITY_SOURCE_DIR) + "/data/characters/duck.character.json";
constexpr double kServerStartLimit = 60.0;  // s
const std::string kKnownBackends = "alternating, alternating-gn, eq5-newton, ipopt, nlopt";

// The port of "serving http://127.0.0.1:PORT/" once the server prints it; 0 if it never does.
int wait_for_port(const std::filesystem::path& logs) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < kServerStartLimit) {
    int port = 0;
    if (std::sscanf(read_text(logs / "stdout").c_str(), "serving http://127.0.0.1:%d/", &port) == 1) return port;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return 0;
}

// The whitespace-separated columns of line `index` (0: the header) of `text`.
std::vector<std::string> columns(const std::string& text, int index) {
  std::istringstream lines(text);
  std::string line;
  for (int k = 0; k <= index; ++k) std::getline(lines, line);
  std::istringstream words(line);
  std::vector<std::string> out;
  for (std::string w; words >> w;) out.push_back(w);
  return out;
}

class ServeSuggestLinkTest : public ::testing::Test {
 protected:
  void SetUp() override {
    pid_ = start_program({"serve", kDuck, "--port", "0"}, server_dir_.logs());
    port_ = wait_for_port(server_dir_.logs());
    ASSERT_GT(port_, 0) << read_text(server_dir_.logs() / "stderr");
  }
  void TearDown() override {
    ::kill(pid_, SIGTERM);
    const int status = wait_program(pid_, 30);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  httplib::Result post(const json& body) const {
    httplib::Client client("127.0.0.1", port_);
    client.set_read_timeout(120, 0);
    return client.Post("/api/suggest-link", body.dump(), "application/json");
  }
  static json duck() { return json::parse(read_text(kDuck)); }

  ScratchDir server_dir_{"serve-suggest"};
  ScratchDir cli_dir_{"serve-suggest-cli"};
  pid_t pid_ = -1;
  int port_ = 0;
};

TEST_F(ServeSuggestLinkTest, RankingEqualsTheCommands) {
  const auto res = post({{"character", duck()}, {"a", "body"}, {"b", "neck"}, {"axis", {0, 1, 0}}, {"range", 20},
                         {"faces", 2}, {"cables", 1}});
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  const json route = json::parse(res->body);

  const std::string file = cli_dir_.file("ranking.json");
  const testing::ProgramRun cli = cli_dir_.run({"suggest-link", kDuck, "--a", "body", "--b", "neck", "--axis", "0", "1",
                                                "0", "--range", "20", "--faces", "2", "--cables", "1", "--json", file});
  ASSERT_EQ(cli.exit_status, 0) << cli.err;
  const json command = json::parse(read_text(file));

  ASSERT_EQ(route["candidates"].size(), command["candidates"].size());
  ASSERT_GE(route["candidates"].size(), 2u);
  for (std::size_t k = 0; k < route["candidates"].size(); ++k) {
    const json& r = route["candidates"][k];
    const json& c = command["candidates"][k];
    EXPECT_EQ(r["type"], c["type"]) << k;
    EXPECT_EQ(r["a"], c["a"]) << k;
    EXPECT_EQ(r["b"], c["b"]) << k;
    ASSERT_TRUE(r["measured"].get<bool>()) << k;
    EXPECT_NEAR(r["about_axis"].get<double>(), c["about_axis"].get<double>(), 1e-9 * c["about_axis"].get<double>());
    EXPECT_NEAR(r["perpendicular"].get<double>(), c["perpendicular"].get<double>(),
                1e-9 * c["perpendicular"].get<double>());
    // The printed table: rank, type, a, b, status, k_min, k_mid, k_max, aniso, k_axis, k_perp (4 digits).
    const std::vector<std::string> row = columns(cli.out, static_cast<int>(k) + 1);
    ASSERT_EQ(row.size(), 11u) << cli.out;
    EXPECT_EQ(row[2], r["a"].get<std::string>());
    const double printed_k_axis = std::stod(row[9]);
    EXPECT_NEAR(r["about_axis"].get<double>(), printed_k_axis, 1e-3 * printed_k_axis) << cli.out;
    EXPECT_NEAR(r["principal_stiffness"][0].get<double>(), std::stod(row[5]), 1e-3 * std::stod(row[5]));
  }
  // The link to apply names the two blocks of the request.
  EXPECT_EQ(route["candidates"][0]["link"]["a"]["block"], "body");
  EXPECT_EQ(route["candidates"][0]["link"]["b"]["block"], "neck");
}

TEST_F(ServeSuggestLinkTest, BadRequestGets400AndTheServerKeepsServing) {
  const auto bad = post({{"character", duck()}, {"a", "body"}, {"b", "neck"}, {"axis", {0, 0, 0}}});
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  const testing::ProgramRun cli =
      cli_dir_.run({"suggest-link", kDuck, "--a", "body", "--b", "neck", "--axis", "0", "0", "0"});
  EXPECT_EQ(cli.exit_status, 2);
  EXPECT_EQ(cli.err, "tensegrity: command line: --axis: must be a finite nonzero vector\n");
  EXPECT_EQ(bad->body, "tensegrity: request: --axis: must be a finite nonzero vector\n");

  // A solver name no registry knows: the request names the option, the program its flag.
  httplib::Client client("127.0.0.1", port_);
  const auto unknown = client.Post("/api/solve", json{{"scene", json::object()}, {"solver", "nope"}}.dump(),
                                   "application/json");
  ASSERT_TRUE(unknown);
  EXPECT_EQ(unknown->status, 400);
  EXPECT_EQ(unknown->body, "tensegrity: request: solver 'nope': unknown backend (known: " + kKnownBackends + ")\n");

  const auto missing = post({{"character", duck()}, {"a", "body"}, {"b", "tail"}, {"stiff", true}});
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 400);
  EXPECT_EQ(missing->body, "tensegrity: request: blocks: no block with id 'tail'\n");

  const auto neither = post({{"character", duck()}, {"a", "body"}, {"b", "neck"}});
  ASSERT_TRUE(neither);
  EXPECT_EQ(neither->status, 400);
  EXPECT_EQ(neither->body, "tensegrity: request: suggest-link: give either --axis X Y Z or --stiff\n");

  const auto good = post({{"character", duck()}, {"a", "body"}, {"b", "neck"}, {"stiff", true}, {"faces", 1},
                          {"cables", 0}});
  ASSERT_TRUE(good);
  ASSERT_EQ(good->status, 200) << good->body;
  const json ranking = json::parse(good->body);
  ASSERT_EQ(ranking["candidates"].size(), 1u);
  EXPECT_EQ(ranking["candidates"][0]["type"], "face");
  EXPECT_GT(ranking["candidates"][0]["principal_stiffness"][0].get<double>(), 0.0);
}

// A second server on a port in use fails at once (no connections split
// between two listeners), and the running one keeps serving.
TEST_F(ServeSuggestLinkTest, PortInUseIsBadInput) {
  const testing::ProgramRun second = cli_dir_.run({"serve", kDuck, "--port", std::to_string(port_)}, 30);
  EXPECT_EQ(second.exit_status, 2);
  EXPECT_EQ(second.err, "tensegrity: command line: --port: cannot listen on 127.0.0.1:" + std::to_string(port_) + "\n");
  httplib::Client client("127.0.0.1", port_);
  const auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
}

// Requests naming another host (DNS rebinding) or sent from another origin
// (a cross-site form) are refused; the app's own origin is served.
TEST_F(ServeSuggestLinkTest, OtherHostsAndOriginsAreRefused) {
  httplib::Client client("127.0.0.1", port_);
  const auto rebound = client.Get("/", {{"Host", "evil.example:" + std::to_string(port_)}});
  ASSERT_TRUE(rebound);
  EXPECT_EQ(rebound->status, 403);
  const std::string body = json{{"scene", json::object()}}.dump();
  const auto cross_site = client.Post("/api/solve", {{"Origin", "http://evil.example"}}, body, "text/plain");
  ASSERT_TRUE(cross_site);
  EXPECT_EQ(cross_site->status, 403);
  EXPECT_EQ(cross_site->body, "tensegrity: request: Origin: 'http://evil.example' is not this server\n");
  const std::string own = "http://127.0.0.1:" + std::to_string(port_);
  const auto same_origin = client.Get("/", {{"Origin", own}});
  ASSERT_TRUE(same_origin);
  EXPECT_EQ(same_origin->status, 200);
  httplib::Client by_name("localhost", port_);
  const auto named = by_name.Get("/");
  ASSERT_TRUE(named);
  EXPECT_EQ(named->status, 200);
}

}  // namespace
}  // namespace tensegrity
