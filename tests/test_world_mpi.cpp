// Distributed world builds (relief/world.hpp, WorldSettings::mpi_module; issue 18): the relief binary
// run by `mpirun --oversubscribe --allow-run-as-root -n P` writes, for P = 1, 2, 4 and for more
// ranks than tiles, the store a build without MPI writes, byte for byte (every tile file, world.json
// with its tile checksums, overview.png); a phased build (a global `fill` stage run by its world
// algorithm on rank 0) too; a distributed build resumes a store that a build without MPI left
// unfinished; bad input exits with code 2 and is printed once. Skipped, saying why, when mpirun
// (openmpi-bin) or the relief_mpi module (built when CMake finds libopenmpi-dev) is missing.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <thread>

#include "relief/world.hpp"
#include "relief/world_bounded.hpp"
#include "support.hpp"
#include "world_support.hpp"

using relief::test::Shell;
using relief::test::TempDir;
namespace fs = std::filesystem;

namespace {

std::string module_path() { return (fs::path(RELIEF_BINARY).parent_path() / "relief_mpi.so").string(); }

// Why the MPI tests cannot run here ("" when they can).
std::string missing_mpi() {
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0) return "mpirun is missing (install openmpi-bin)";
  if (!fs::exists(module_path()))
    return "the relief_mpi module " + module_path() + " was not built (CMake did not find MPI: install libopenmpi-dev)";
  return "";
}

#define REQUIRE_MPI()                                          \
  do {                                                         \
    const std::string why = missing_mpi();                     \
    if (!why.empty()) GTEST_SKIP() << "MPI tests skipped: " << why; \
  } while (0)

// The start of a shell command that runs MPI programs: Open MPI's own allocations are still held at
// exit, which LeakSanitizer would report from the sanitizer build's ranks (scripts/test.sh runs it
// with detect_leaks=1), so leak detection is off in them; nothing changes in other builds.
const std::string kMpiEnv = "ASAN_OPTIONS=\"${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0\" ";

// `relief ARGS` on `ranks` ranks (CI runs as root on 2 cores: --oversubscribe --allow-run-as-root).
Shell mpirun(int ranks, const std::string& args) {
  return relief::test::sh(kMpiEnv + "mpirun --oversubscribe --allow-run-as-root -n " + std::to_string(ranks) + " " + RELIEF_BINARY +
                          " " + args);
}

void expect_same_store(const fs::path& ref, const fs::path& got) {
  // Every regular file (relative path → bytes) but report.json (times, ranks).
  const auto a = relief::test::world::store_files(ref), b = relief::test::world::store_files(got);
  EXPECT_EQ(a.size(), b.size());
  std::size_t tiles = 0;
  for (auto& [name, bytes] : a) {
    const auto it = b.find(name);
    if (it == b.end()) {
      ADD_FAILURE() << name << " is missing";
      continue;
    }
    EXPECT_TRUE(bytes == it->second) << name << " differs";
    tiles += name.ends_with(".rtile");
  }
  for (auto& [name, bytes] : b)
    if (!a.count(name)) ADD_FAILURE() << name << " is not in the reference store";
  EXPECT_GT(tiles, 0u);
  EXPECT_TRUE(relief::verify_world(got.string()).empty());
  // The manifest's tile checksums (compared whole above) describe complete tiles.
  EXPECT_EQ(relief::read_world_manifest(got.string())["status"], "complete");
}

relief::json report_of(const fs::path& dir) { return relief::json::parse(relief::test::slurp(dir / "report.json")); }

// The ranks' tiles add up to the world's, and report.json says how many ranks built it.
void expect_ranks(const fs::path& dir, int ranks, std::int64_t built) {
  const relief::json rep = report_of(dir);
  EXPECT_EQ(rep["performance"]["ranks"], ranks);
  const relief::json by_rank = rep["tiles"]["built_by_rank"];
  ASSERT_EQ(by_rank.size(), std::size_t(ranks)) << rep.dump();
  std::int64_t sum = 0;
  for (const auto& n : by_rank) sum += n.get<std::int64_t>();
  EXPECT_EQ(sum, built) << rep.dump();
  EXPECT_EQ(rep["tiles"]["built"], built);
}

const std::string kArgs = "world island --size 257 --tile 33 --seed 4 -q -j 1";  // 64 tiles

// The island with a global `fill` stage after its third stage (and the rest after it when `after`).
relief::json fill_doc(bool after) {
  relief::json doc = relief::load_preset("island");
  relief::json stages = relief::json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2],
                                             relief::json{{"stage", "fill"}, {"epsilon_m", 0.01}}});
  if (after)
    for (std::size_t k = 3; k < doc["stages"].size(); ++k) stages.push_back(doc["stages"][k]);
  doc["stages"] = stages;
  return doc;
}

// eroded-mountains up to its stream power stage, of 5 steps.
relief::json stream_power_doc() {
  relief::json doc = relief::load_preset("eroded-mountains");
  relief::json stages = relief::json::array();
  for (const relief::json& st : doc["stages"]) {
    stages.push_back(st);
    if (st["stage"] == "stream_power") {
      stages.back()["steps"] = 5;
      break;
    }
  }
  doc["stages"] = stages;
  doc["seed"] = 5;
  return doc;
}

// A world algorithm standing in for `fill` in WorldMpiPhases: each tile's heights raised by
// 0.001·(X + 2·Z + 1), a change that is easy to get wrong (tile order, lost stores) and cheap.
relief::WorldStageAlgorithm raise_tiles() {
  return [](const relief::WorldStageIO& io, const relief::RecipeStage&, int) {
    for (std::int64_t Z = 0; Z < io.grid.tiles_z; ++Z)
      for (std::int64_t X = 0; X < io.grid.tiles_x; ++X) {
        relief::WorldTile t = io.load(X, Z);
        for (float& h : t.layers.at("height").data) h += 0.001f * float(X + 2 * Z + 1);
        io.store(X, Z, std::move(t));
      }
  };
}

}  // namespace

// Not a test on its own: the program that WorldMpi.PhasesWithAWorldAlgorithm runs on every rank
// under mpirun (and once without it, for the reference), a library build_world with a world
// algorithm registered for `fill`. Skipped when RELIEF_TEST_MPI_OUT does not say where to build.
TEST(WorldMpiRank, BuildsThePhasedWorldNamedByTheEnvironment) {
  const char* out = std::getenv("RELIEF_TEST_MPI_OUT");
  if (!out || !*out) GTEST_SKIP() << "run by WorldMpi.PhasesWithAWorldAlgorithmAreTheSameOnOneTwoAndFourRanks";
  const char* after = std::getenv("RELIEF_TEST_MPI_AFTER");
  const char* stage = std::getenv("RELIEF_TEST_MPI_STAGE");
  relief::WorldSettings s;
  s.threads = 1;
  s.out_dir = out;
  if (stage && std::string(stage) == "stream_power") {
    // eroded-mountains up to its stream power (5 steps), refined: coarse 65², blocks of 64 grown by
    // 16, 3 sweeps (the blocks of each sweep are farm tasks, src/world_bounded.cpp).
    s.recipe = relief::parse_recipe(stream_power_doc());
    s.nx = s.nz = 257;
    s.tile = 65;
    s.algorithms["stream_power"] = relief::world_stream_power(65, 64, 16, 3);
  } else {
    relief::json doc = fill_doc(after && *after == '1');
    doc["seed"] = 3;
    s.recipe = relief::parse_recipe(doc);
    s.nx = s.nz = 129;
    s.tile = 33;
    s.algorithms["fill"] = raise_tiles();
  }
  if (std::getenv("OMPI_COMM_WORLD_SIZE")) s.mpi_module = module_path();
  const relief::WorldReport rep = relief::build_world(s);
  EXPECT_EQ(rep.ranks, std::getenv("OMPI_COMM_WORLD_SIZE") ? std::atoi(std::getenv("OMPI_COMM_WORLD_SIZE")) : 1);
}

// A global stage run by its world algorithm on rank 0 over the tiles every rank wrote (between two
// local phases, and as the last stage): the same store on 1, 2 and 4 ranks as in one process.
TEST(WorldMpi, PhasesWithAWorldAlgorithmAreTheSameOnOneTwoAndFourRanks) {
  REQUIRE_MPI();
  TempDir d("world-mpi-phases");
  const std::string self = (fs::path(RELIEF_BINARY).parent_path() / "tests" / "test_world_mpi").string();
  ASSERT_TRUE(fs::exists(self)) << self;
  const std::string filter = " --gtest_filter=WorldMpiRank.BuildsThePhasedWorldNamedByTheEnvironment --gtest_brief=1";
  for (const char* after : {"1", "0"}) {
    SCOPED_TRACE(std::string("stages after fill: ") + after);
    const std::string env = std::string("RELIEF_TEST_MPI_AFTER=") + after + " ";
    const std::string ref = d / (std::string("ref") + after);
    const Shell one = relief::test::sh(env + "RELIEF_TEST_MPI_OUT=" + ref + " " + self + filter);
    ASSERT_EQ(one.code, 0) << one.out;
    expect_ranks(ref, 1, after[0] == '1' ? 32 : 16);
    for (int ranks : {1, 2, 4}) {
      SCOPED_TRACE(std::to_string(ranks) + " ranks");
      const std::string out = d / (std::string("p") + after + "-" + std::to_string(ranks));
      const Shell r = relief::test::sh(kMpiEnv + "mpirun --oversubscribe --allow-run-as-root -n " + std::to_string(ranks) + " -x RELIEF_TEST_MPI_OUT=" +
                                       out + " -x RELIEF_TEST_MPI_AFTER=" + after + " " + self + filter);
      ASSERT_EQ(r.code, 0) << r.out;
      expect_same_store(ref, out);
      EXPECT_FALSE(fs::exists(fs::path(out) / "phase-0"));  // intermediate phases removed
      expect_ranks(out, ranks, after[0] == '1' ? 32 : 16);
    }
  }
}

TEST(WorldMpi, OneTwoAndFourRanksWriteTheStoreOfABuildWithoutMpi) {
  REQUIRE_MPI();
  TempDir d("world-mpi");
  const Shell ref = relief::test::relief_cli(kArgs + " -o " + (d / "ref"));
  ASSERT_EQ(ref.code, 0) << ref.out;
  expect_ranks(d.path / "ref", 1, 64);
  for (int ranks : {1, 2, 4}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const std::string out = d / ("p" + std::to_string(ranks));
    const Shell r = mpirun(ranks, kArgs + " -o " + out);
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(r.out.empty()) << r.out;  // -q: nothing from any rank
    expect_same_store(d.path / "ref", out);
    expect_ranks(out, ranks, 64);
  }
}

TEST(WorldMpi, MoreRanksThanTilesStillBuildTheWorld) {
  REQUIRE_MPI();
  TempDir d("world-mpi-few");
  const std::string args = "world hills --size 65x33 --tile 33 --seed 2 -q";  // 2 tiles
  const Shell ref = relief::test::relief_cli(args + " -o " + (d / "ref"));
  ASSERT_EQ(ref.code, 0) << ref.out;
  const Shell r = mpirun(5, args + " -o " + (d / "p5"));
  ASSERT_EQ(r.code, 0) << r.out;
  expect_same_store(d.path / "ref", d.path / "p5");
  expect_ranks(d.path / "p5", 5, 2);
}

// The tile solves of global phases each rank ran (report.json), and their sum.
std::vector<std::int64_t> global_solves(const fs::path& dir, std::int64_t& sum) {
  const relief::json rep = report_of(dir);
  std::vector<std::int64_t> v = rep["tiles"]["global_solves_by_rank"].get<std::vector<std::int64_t>>();
  sum = 0;
  for (std::int64_t n : v) sum += n;
  return v;
}

// The CLI with the `fill` stage between local phases: fill runs by its world algorithm, rank 0
// keeping the border levels and handing out the tile solves of each round to every rank
// (src/world_farm.hpp), over the tiles the ranks wrote; then every rank builds the next phase's
// tiles from them.
TEST(WorldMpi, TheCliWithTheFillStageIsTheSameOnTwoAndFourRanks) {
  REQUIRE_MPI();
  TempDir d("world-mpi-fill");
  relief::test::write_text(d.path / "fill.json", fill_doc(true).dump());
  // Tiles of 65: a solve takes long enough (about a millisecond) that the other ranks get some.
  const std::string args = "world " + (d / "fill.json") + " --size 257 --tile 65 --seed 3 -q -j 1";
  const Shell ref = relief::test::relief_cli(args + " -o " + (d / "ref"));
  if (ref.code == 2 && ref.out.find("no world support") != std::string::npos)
    GTEST_SKIP() << "this relief has no world algorithm for fill yet: " << ref.out;
  ASSERT_EQ(ref.code, 0) << ref.out;
  ASSERT_EQ(relief::read_world_manifest(d / "ref")["stages"][3]["locality"], "global");  // run by a world algorithm
  std::int64_t solves = 0;
  EXPECT_EQ(global_solves(d.path / "ref", solves).size(), 1u);
  EXPECT_GE(solves, 16);  // every tile once at least, all in this process
  for (int ranks : {2, 4}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const std::string out = d / ("p" + std::to_string(ranks));
    const Shell r = mpirun(ranks, args + " -o " + out);
    ASSERT_EQ(r.code, 0) << r.out;
    expect_same_store(d.path / "ref", out);
    EXPECT_FALSE(fs::exists(fs::path(out) / "phase-0"));  // intermediate phase removed
    expect_ranks(out, ranks, 2 * 16);                      // two local phases of 16 tiles
    // The same solves (a fixed schedule), spread: ranks other than 0 ran some of them.
    std::int64_t sum = 0;
    const std::vector<std::int64_t> by_rank = global_solves(out, sum);
    ASSERT_EQ(by_rank.size(), std::size_t(ranks));
    EXPECT_EQ(sum, solves);
    EXPECT_GT(sum - by_rank[0], 0);
  }
}

// The CLI with the `flow` stage (rivers, lakes; relief/world_flow.hpp): its tile solves run on
// every rank (src/world_farm.hpp) and the store, rivers.json and lakes.json are the bytes of a
// build without MPI on 1, 2 and 4 ranks: after a fill stage, and without one, where the first pass
// finds a height that does not drain (a status sent back by whichever rank solved the tile) and
// rank 0 fills first, then runs the tile solves on every rank again.
TEST(WorldMpi, TheCliWithTheFlowStageIsTheSameOnOneTwoAndFourRanks) {
  REQUIRE_MPI();
  TempDir d("world-mpi-flow");
  for (const bool fill : {true, false}) {
    SCOPED_TRACE(fill ? "after a fill stage" : "without a fill stage");
    relief::json doc = relief::load_preset("island");
    relief::json stages = relief::json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2]});
    if (fill) stages.push_back(relief::json{{"stage", "fill"}, {"epsilon_m", 0.01}});
    stages.push_back(relief::json{{"stage", "flow"}, {"river_area_km2", 0.02}, {"width_coeff", 300.0}, {"carve_depth_coeff", 1.0}});
    stages.push_back(doc["stages"][3]);  // a local phase after flow
    doc["stages"] = stages;
    const std::string name = fill ? "fill-flow" : "flow";
    relief::test::write_text(d.path / (name + ".json"), doc.dump());
    const std::string args = "world " + (d / (name + ".json")) + " --size 257 --tile 65 --seed 3 -q -j 1";
    const fs::path ref = d.path / (name + "-ref");
    const Shell one = relief::test::relief_cli(args + " -o " + ref.string());
    ASSERT_EQ(one.code, 0) << one.out;
    const std::size_t flow_stage = fill ? 4 : 3;
    ASSERT_EQ(relief::read_world_manifest(ref.string())["stages"][flow_stage]["locality"], "global");
    EXPECT_GT(relief::json::parse(relief::test::slurp(ref / "rivers.json"))["count"].get<int>(), 0);
    if (!fill) {
      EXPECT_GT(relief::json::parse(relief::test::slurp(ref / "lakes.json"))["count"].get<int>(), 0);  // the fill's depressions
    }
    std::int64_t solves = 0;
    EXPECT_EQ(global_solves(ref, solves).size(), 1u);
    EXPECT_GE(solves, 2 * 16);  // pass A's and the final pass's at least, all in this process
    // Without a fill stage: the same recipe with a fill stage of flow's epsilon (0) before flow, in
    // one process, runs the solves of the fallback fill (the same heights, sea level and epsilon: the
    // same schedule) and of flow on the filled heights; the fallback also runs the first attempt's
    // pass A (1 to 16 solves until the tile that does not drain). So the fallback fill's solves are
    // farm tasks (global_solves_by_rank) when the no-fill build has more solves than that build.
    std::int64_t fill_then_flow = 0;
    if (!fill) {
      relief::json both = doc;
      both["stages"] = relief::json::array({stages[0], stages[1], stages[2], relief::json{{"stage", "fill"}, {"epsilon_m", 0.0}}, stages[3], stages[4]});
      relief::test::write_text(d.path / "fill0-flow.json", both.dump());
      const fs::path both_ref = d.path / "fill0-flow-ref";
      const Shell b = relief::test::relief_cli("world " + (d / "fill0-flow.json") + " --size 257 --tile 65 --seed 3 -q -j 1 -o " + both_ref.string());
      ASSERT_EQ(b.code, 0) << b.out;
      global_solves(both_ref, fill_then_flow);
      EXPECT_GT(solves, fill_then_flow);
      EXPECT_LE(solves, fill_then_flow + 16);
    }
    for (int ranks : {1, 2, 4}) {
      SCOPED_TRACE(std::to_string(ranks) + " ranks");
      const fs::path out = d.path / (name + "-p" + std::to_string(ranks));
      const Shell r = mpirun(ranks, args + " -o " + out.string());
      ASSERT_EQ(r.code, 0) << r.out;
      expect_same_store(ref, out);  // every tile, world.json, rivers.json, lakes.json
      std::int64_t sum = 0;
      const std::vector<std::int64_t> by_rank = global_solves(out, sum);
      ASSERT_EQ(by_rank.size(), std::size_t(ranks));
      // Without a fill stage, every global solve is flow's or its fallback fill's ("flow-fill"
      // tasks): some ran on the other ranks, and the fill's were farm tasks on any rank count (see
      // above; one process, or rank 0 alone, ran them outside the farm before).
      if (ranks > 1 && !fill) {
        EXPECT_GT(sum - by_rank[0], 0);
      }
      if (!fill) {
        EXPECT_GT(sum, fill_then_flow);
        EXPECT_LE(sum, fill_then_flow + 16);
      }
      if (fill) {
        // Fill's solves and flow's (pass A and the final pass: 16 each, pass S's rounds): a fixed
        // schedule, the same as in one process.
        EXPECT_EQ(sum, solves);
        EXPECT_GE(sum, 3 * 16);
      }
    }
  }
}

// Droplet erosion's passes (relief/world_bounded.hpp) spread over the ranks: each rank runs groups of
// world blocks on the windows rank 0 sends and sends back the samples they changed; the store is the
// bytes of a build without MPI (which are the whole map's: tests/test_world_bounded.cpp).
TEST(WorldMpi, HydraulicPassesSpreadOverTwoRanksGiveTheSameBytes) {
  REQUIRE_MPI();
  TempDir d("world-mpi-hydraulic");
  relief::json doc = relief::load_preset("island");
  doc["stages"] = relief::json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2],
                                       relief::json{{"stage", "hydraulic"}, {"droplets_per_km2", 2000}}});
  relief::test::write_text(d.path / "hydraulic.json", doc.dump());
  const std::string args = "world " + (d / "hydraulic.json") + " --size 513 --tile 129 --seed 3 -q -j 1";
  const Shell ref = relief::test::relief_cli(args + " -o " + (d / "ref"));
  ASSERT_EQ(ref.code, 0) << ref.out;
  ASSERT_EQ(relief::read_world_manifest(d / "ref")["stages"][3]["world"], "exact");
  const Shell r = mpirun(2, args + " -o " + (d / "p2"));
  ASSERT_EQ(r.code, 0) << r.out;
  expect_same_store(d.path / "ref", d.path / "p2");
  std::int64_t sum = 0;
  const std::vector<std::int64_t> by_rank = global_solves(d.path / "p2", sum);
  ASSERT_EQ(by_rank.size(), 2u);
  EXPECT_GE(sum, 16);  // 16 passes, several groups each (smaller groups with more ranks)
  EXPECT_GT(by_rank[1], 0);
}

// Stream power's refinement (relief/world_bounded.hpp): the blocks of every sweep are farm tasks
// (rank 0 sends a block's window, ring levels and records; the rank that solves it sends back what it
// gives its neighbours, or its solved window in the last sweep), merged in block order: the store is
// the bytes of a build in one process, and the other ranks solve some of the blocks.
TEST(WorldMpi, StreamPowerBlocksSpreadOverTwoAndThreeRanksGiveTheSameBytes) {
  REQUIRE_MPI();
  TempDir d("world-mpi-stream-power");
  const std::string self = (fs::path(RELIEF_BINARY).parent_path() / "tests" / "test_world_mpi").string();
  const std::string filter = " --gtest_filter=WorldMpiRank.BuildsThePhasedWorldNamedByTheEnvironment --gtest_brief=1";
  const std::string ref = d / "ref";
  const Shell one = relief::test::sh("RELIEF_TEST_MPI_STAGE=stream_power RELIEF_TEST_MPI_OUT=" + ref + " " + self + filter);
  ASSERT_EQ(one.code, 0) << one.out;
  std::int64_t solves = 0;
  ASSERT_EQ(global_solves(ref, solves).size(), 1u);
  EXPECT_EQ(solves, 16 * 3);  // 4 × 4 blocks, 3 sweeps, all in this process
  for (int ranks : {2, 3}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const std::string out = d / ("p" + std::to_string(ranks));
    const Shell r = relief::test::sh(kMpiEnv + "mpirun --oversubscribe --allow-run-as-root -n " + std::to_string(ranks) +
                                     " -x RELIEF_TEST_MPI_STAGE=stream_power -x RELIEF_TEST_MPI_OUT=" + out + " " + self + filter);
    ASSERT_EQ(r.code, 0) << r.out;
    expect_same_store(ref, out);
    std::int64_t sum = 0;
    const std::vector<std::int64_t> by_rank = global_solves(out, sum);
    ASSERT_EQ(by_rank.size(), std::size_t(ranks));
    EXPECT_EQ(sum, 16 * 3);
    std::int64_t others = 0;
    for (std::size_t k = 1; k < by_rank.size(); ++k) others += by_rank[k];
    EXPECT_GT(others, 0);
  }
}

// A store left unfinished (tiles missing, the manifest still "building") by a build without MPI
// is finished by a distributed one, which skips the tiles that are there.
TEST(WorldMpi, ADistributedBuildResumesAnUnfinishedStore) {
  REQUIRE_MPI();
  TempDir d("world-mpi-resume");
  const Shell ref = relief::test::relief_cli(kArgs + " -o " + (d / "ref"));
  ASSERT_EQ(ref.code, 0) << ref.out;
  fs::copy(d.path / "ref", d.path / "part", fs::copy_options::recursive);
  relief::json manifest = relief::read_world_manifest(d / "part");
  manifest["status"] = "building";
  manifest.erase("tiles");
  relief::test::write_text(d.path / "part" / "world.json", manifest.dump(2) + "\n");
  fs::remove(d.path / "part" / "overview.png");
  int removed = 0;
  for (int k : {0, 5, 17, 40, 63}) removed += fs::remove(d.path / "part" / relief::world_tile_path(k % 8, k / 8));
  ASSERT_EQ(removed, 5);
  const Shell r = mpirun(2, kArgs + " -o " + (d / "part"));
  ASSERT_EQ(r.code, 0) << r.out;
  expect_same_store(d.path / "ref", d.path / "part");
  const relief::json rep = report_of(d.path / "part");
  EXPECT_EQ(rep["tiles"]["built"], 5);
  EXPECT_EQ(rep["tiles"]["skipped"], 59);
}

// SIGKILL of mpirun part way through: its ranks go too (they lose mpirun), the finished tiles stay,
// and a distributed rerun finishes the store with the bytes of an uninterrupted build without MPI.
TEST(WorldMpi, AfterSigkillOfMpirunADistributedRerunGivesTheSameBytes) {
  REQUIRE_MPI();
  TempDir d("world-mpi-kill");
  // 4096 tiles of 17: a rank takes about a second to notice that mpirun is gone and builds tiles
  // until then, so the world must take several seconds (1024 tiles of 33 took 1.6 s on a Zen 4, and
  // the ranks finished them all after the kill); the samples stay few, the reference build cheap.
  const std::string args = "world island --size 1025 --tile 17 --seed 6 -q -j 1";
  const Shell ref = relief::test::relief_cli(args + " -o " + (d / "ref"));
  ASSERT_EQ(ref.code, 0) << ref.out;
  const fs::path out = d.path / "w";
  auto tiles_in = [&] {
    std::error_code ec;
    std::size_t n = 0;
    for (const auto& e : fs::directory_iterator(out / "tiles", ec)) n += e.path().extension() == ".rtile";
    return n;
  };
  const std::string cmd = kMpiEnv + "exec mpirun --oversubscribe --allow-run-as-root -n 2 " + std::string(RELIEF_BINARY) + " " + args +
                          " -o " + out.string() + " >/dev/null 2>&1";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), (char*)nullptr);
    ::_exit(127);
  }
  int st = 0;
  bool exited = false;
  const auto t0 = std::chrono::steady_clock::now();
  while (!exited && tiles_in() < 100 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60)) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    exited = ::waitpid(pid, &st, WNOHANG) == pid;
  }
  if (!exited) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &st, 0);
  }
  // The ranks notice that mpirun is gone and leave; those still there after 30 s are ended here.
  // (The pattern's "[/]" keeps pgrep from finding the shell that runs it.)
  const std::string ranks_of = "pgrep -f -- '-o [/]" + out.string().substr(1) + "'";
  for (int k = 0; k < 300 && !relief::test::sh(ranks_of).out.empty(); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::stringstream left(relief::test::sh(ranks_of).out);
  for (long p; left >> p;) {
    ADD_FAILURE() << "rank " << p << " still ran 30 s after mpirun was killed";
    ::kill(pid_t(p), SIGKILL);
  }
  const std::size_t kept = tiles_in();
  const Shell again = mpirun(2, args + " -o " + out.string());
  ASSERT_EQ(again.code, 0) << again.out;
  expect_same_store(d.path / "ref", out);
  if (WIFSIGNALED(st)) {  // killed part way (not after the build had finished): it resumed
    EXPECT_EQ(report_of(out)["tiles"]["skipped"], kept);
    EXPECT_GT(kept, 0u);
    EXPECT_LT(kept, 4096u);
  }
}

// A tile that no rank can write (a folder stands at its path): whichever rank builds it fails, the
// round stops on every rank, and the build exits with code 2, the error printed once (by rank 0).
TEST(WorldMpi, ATileThatCannotBeWrittenFailsEveryRankWithOneMessage) {
  REQUIRE_MPI();
  TempDir d("world-mpi-unwritable");
  for (int k : {9, 30, 45, 62}) fs::create_directories(d.path / "w" / relief::world_tile_path(k % 8, k / 8));
  for (int ranks : {2, 3}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const Shell r = mpirun(ranks, kArgs + " -o " + (d / "w"));
    EXPECT_EQ(r.code, 2) << r.out;
    const std::size_t at = r.out.find("relief: error: --out:");
    ASSERT_NE(at, std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("relief: error:", at + 1), std::string::npos) << "printed by more than one rank:\n" << r.out;
    EXPECT_EQ(relief::read_world_manifest(d / "w")["status"], "building");  // not marked complete
  }
}

TEST(WorldMpi, BadInputExitsWithCode2AndRankZeroAloneSaysWhy) {
  REQUIRE_MPI();
  TempDir d("world-mpi-bad");
  // --mpi without the module (no mpirun: a singleton would start).
  const Shell nomod = relief::test::sh(std::string("RELIEF_MPI_MODULE=").append(d / "none.so").append(" ").append(RELIEF_BINARY) +
                                       " world island --size 65 --tile 33 --mpi -o " + (d / "a"));
  EXPECT_EQ(nomod.code, 2) << nomod.out;
  EXPECT_NE(nomod.out.find("--mpi: expected the MPI module"), std::string::npos) << nomod.out;
  EXPECT_FALSE(fs::exists(d.path / "a" / "world.json"));
  // A file that is not the module.
  relief::test::write_text(d.path / "fake.so", "not a shared object");
  const Shell fake = relief::test::sh(std::string("RELIEF_MPI_MODULE=").append(d / "fake.so").append(" ").append(RELIEF_BINARY) +
                                      " world island --size 65 --tile 33 --mpi -o " + (d / "a"));
  EXPECT_EQ(fake.code, 2) << fake.out;
  EXPECT_NE(fake.out.find("--mpi: cannot load the MPI module"), std::string::npos) << fake.out;
  // Under mpirun: a bad tile size is refused by every rank, printed by rank 0 only.
  const Shell tile = mpirun(3, "world island --size 129 --tile 64 -o " + (d / "b"));
  EXPECT_EQ(tile.code, 2) << tile.out;
  const std::string needle = "relief: error: --tile: expected a tile size of 2^n+1";
  const std::size_t first = tile.out.find(needle);
  ASSERT_NE(first, std::string::npos) << tile.out;
  EXPECT_EQ(tile.out.find(needle, first + 1), std::string::npos) << "printed by more than one rank:\n" << tile.out;
  // A folder holding another world: found by rank 0, thrown on every rank, printed once.
  ASSERT_EQ(relief::test::relief_cli("world island --size 65 --tile 33 --seed 1 -q -o " + (d / "c")).code, 0);
  const Shell other = mpirun(2, "world island --size 65 --tile 33 --seed 2 -q -o " + (d / "c"));
  EXPECT_EQ(other.code, 2) << other.out;
  const std::size_t at = other.out.find("relief: error: --out: the folder");
  ASSERT_NE(at, std::string::npos) << other.out;
  EXPECT_EQ(other.out.find("relief: error:", at + 1), std::string::npos) << "printed by more than one rank:\n" << other.out;
}
