// World builds report progress inside their global phases (WorldProgress::phase_fraction,
// WorldStageIO::progress; relief/world.hpp), without changing a byte of the world; and the disk
// check estimates the store from coded sample windows, not from zlib's worst case ("Disk and
// memory" in relief/world.hpp; issue 18).
#include <gtest/gtest.h>
#include <pty.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include "relief/error.hpp"
#include "relief/world.hpp"
#include "relief/world_bounded.hpp"
#include "support.hpp"
#include "world_support.hpp"

using namespace relief;
using namespace relief::test::world;
using relief::test::TempDir;

namespace {

struct Seen {
  std::string stage;
  double phase = -1, fraction = 0, seconds_left = -1;
};

std::vector<Seen> build_watching(const Recipe& r, const fs::path& dir, int threads, WorldReport* rep = nullptr) {
  std::vector<Seen> seen;
  WorldSettings s = settings(r, 257, 257, 65, dir.string(), threads);
  s.progress = [&](const WorldProgress& p) { seen.push_back({std::string(p.stage_name), p.phase_fraction, p.fraction, p.seconds_left}); };
  const WorldReport got = build_world(s);
  if (rep) *rep = got;
  return seen;
}

}  // namespace

// Phases of the river world: [noise, island, redistribute] | fill | flow | [color, hillshade].
// Inside fill and flow the callback hears several reports, each phase's share never decreases, starts
// at 0 and ends at 1, and the build's fraction never decreases and moves during those phases.
TEST(WorldProgress, GlobalPhasesReportTheirShareAsTheyGo) {
  const Recipe r = recipe_of(river_world_doc(), 5);
  TempDir d("world-progress-global");
  const std::vector<Seen> seen = build_watching(r, d / "w", 1);
  ASSERT_FALSE(seen.empty());
  for (std::size_t k = 1; k < seen.size(); ++k) EXPECT_GE(seen[k].fraction, seen[k - 1].fraction) << k;
  EXPECT_DOUBLE_EQ(seen.back().fraction, 1.0);
  for (const char* stage : {"fill", "flow"}) {
    std::vector<const Seen*> in;
    for (const Seen& s : seen)
      if (s.phase >= 0 && s.stage == stage) in.push_back(&s);
    ASSERT_GE(in.size(), 8u) << stage;  // 16 tiles, each merged at least once
    EXPECT_EQ(in.front()->phase, 0.0) << stage;
    EXPECT_EQ(in.back()->phase, 1.0) << stage;
    int inside = 0;
    for (std::size_t k = 1; k < in.size(); ++k) {
      EXPECT_GE(in[k]->phase, in[k - 1]->phase) << stage << " " << k;
      EXPECT_GE(in[k]->fraction, in[k - 1]->fraction) << stage << " " << k;
      inside += in[k]->phase > 0 && in[k]->phase < 1;
      if (in[k]->phase > 0.01) {
        EXPECT_GE(in[k]->seconds_left, 0.0) << stage << " " << k;  // the phase's own pace
      }
    }
    EXPECT_GE(inside, 4) << stage;
    // The build's fraction moves during the phase (each global phase counts as a pass over the tiles).
    EXPECT_GT(in.back()->fraction, in.front()->fraction + 0.05) << stage;
    EXPECT_LT(in.front()->fraction, 1.0) << stage;
  }
  // Local phases report no phase share.
  for (const Seen& s : seen)
    if (s.stage == "noise" || s.stage == "hillshade") {
      EXPECT_EQ(s.phase, -1.0);
    }
}

// A flow stage with no fill before it fills first (world_flow): its share still never decreases
// across the failed first attempt, the fill and the second attempt, and ends at 1.
TEST(WorldProgress, FlowWithoutFillStillReportsAnIncreasingShare) {
  json doc = river_world_doc();
  json stages = json::array();
  for (const json& st : doc["stages"])
    if (st.value("stage", "") != "fill") stages.push_back(st);
  doc["stages"] = stages;
  const Recipe r = recipe_of(doc, 5);
  TempDir d("world-progress-nofill");
  const std::vector<Seen> seen = build_watching(r, d / "w", 2);
  std::vector<double> flow;
  for (const Seen& s : seen)
    if (s.phase >= 0 && s.stage == "flow") flow.push_back(s.phase);
  ASSERT_GE(flow.size(), 8u);
  EXPECT_TRUE(std::is_sorted(flow.begin(), flow.end()));
  EXPECT_EQ(flow.back(), 1.0);
}

// The bounded erosion stages report their share too: hydraulic a step per tile, stream power its
// gathering pass, coarse solve and writing pass (the eroded-mountains preset's stages up to
// hydraulic, at 513² in tiles of 129).
TEST(WorldProgress, BoundedErosionPhasesReportTheirShare) {
  json doc = load_preset("eroded-mountains");
  json stages = json::array();
  for (const json& st : doc["stages"]) {
    json c = st;
    if (c.value("stage", "") == "stream_power") c["steps"] = 5;
    stages.push_back(c);
    if (c.value("stage", "") == "hydraulic") break;
  }
  doc["stages"] = stages;
  const Recipe r = recipe_of(doc, 5);
  TempDir d("world-progress-bounded");
  std::vector<Seen> seen;
  WorldSettings s = settings(r, 257, 257, 65, d / "w", 2);
  s.progress = [&](const WorldProgress& p) { seen.push_back({std::string(p.stage_name), p.phase_fraction, p.fraction, p.seconds_left}); };
  build_world(s);
  for (const char* stage : {"stream_power", "hydraulic"}) {
    std::vector<double> in;
    for (const Seen& x : seen)
      if (x.phase >= 0 && x.stage == stage) in.push_back(x.phase);
    ASSERT_FALSE(in.empty()) << stage;
    EXPECT_TRUE(std::is_sorted(in.begin(), in.end())) << stage;
    EXPECT_EQ(in.back(), 1.0) << stage;
    // 16 tiles (4 × 4): reports strictly inside the phase, not only its start and end.
    EXPECT_GE(std::count_if(in.begin(), in.end(), [](double f) { return f > 0 && f < 1; }), 4) << stage;
  }
}

// Listening changes no byte: a build with a callback equals one without, for 1 and 2 threads.
TEST(WorldProgress, ACallbackChangesNoByteOfTheWorld) {
  const Recipe r = recipe_of(river_world_doc(), 6);
  TempDir d("world-progress-bytes");
  build_world(settings(r, 257, 257, 65, d / "plain", 1));
  build_watching(r, d / "heard1", 1);
  build_watching(r, d / "heard2", 2);
  expect_same_store(d.path / "plain", d.path / "heard1");
  expect_same_store(d.path / "plain", d.path / "heard2");
}

// The CLI without -q on a terminal: its progress line names fill and flow with their share as they
// run (the line is drawn on a terminal only, so the command runs on a pseudo-terminal here).
TEST(WorldProgress, TheCliDrawsTheGlobalPhasesShareOnATerminal) {
  TempDir d("world-progress-cli");
  relief::test::write_text(d / "river.json", river_world_doc().dump());
  const std::string recipe = d / "river.json";
  auto on_terminal = [&](const std::string& out, bool quiet) {
    int fd = -1;
    const pid_t pid = ::forkpty(&fd, nullptr, nullptr, nullptr);
    if (pid < 0) {
      ADD_FAILURE() << "forkpty failed";
      return std::string();
    }
    if (pid == 0) {
      std::vector<const char*> argv = {RELIEF_BINARY, "world", recipe.c_str(), "--size", "257", "--tile", "65", "--seed", "3", "-j", "1"};
      if (quiet) argv.push_back("-q");
      argv.insert(argv.end(), {"-o", out.c_str(), nullptr});
      ::execv(RELIEF_BINARY, const_cast<char* const*>(argv.data()));
      ::_exit(127);
    }
    std::string text;
    char buf[4096];
    for (;;) {
      const ssize_t n = ::read(fd, buf, sizeof buf);
      if (n > 0) text.append(buf, std::size_t(n));
      else if (n < 0 && errno == EINTR) continue;
      else break;  // EIO once the child has gone
    }
    ::close(fd);
    int st = 0;
    ::waitpid(pid, &st, 0);
    EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << text;
    return text;
  };
  const std::string text = on_terminal(d / "w", false);
  for (const char* stage : {"fill", "flow"}) {
    int lines = 0;
    bool middle = false;  // a share strictly between 0 and 100 %
    for (std::size_t at = text.find(std::string(stage) + " "); at != std::string::npos; at = text.find(std::string(stage) + " ", at + 1)) {
      const int pct = std::atoi(text.c_str() + at + std::string(stage).size() + 1);
      ++lines;
      middle = middle || (pct > 0 && pct < 100);
    }
    EXPECT_GE(lines, 3) << stage << "\n" << text;
    EXPECT_TRUE(middle) << stage << "\n" << text;
  }
  // The line counts the tiles of the local phases (16 tiles, 2 local phases) and stages (7), and
  // estimates the time left.
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(tiles \d+/32)"))) << text;
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(stage [1-7]/7 )"))) << text;
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(, \d+ s left)"))) << text;
  // -q: no progress line, even on a terminal.
  const std::string quiet = on_terminal(d / "q", true);
  EXPECT_EQ(quiet.find("tiles "), std::string::npos) << quiet;
  EXPECT_EQ(quiet.find("s left"), std::string::npos) << quiet;
}

// ---- the disk estimate --------------------------------------------------------------------------

// The estimate of the last store lies between the store's real size and three times it (coded
// sample windows with a margin of 2, not zlib's worst case of the raw floats), for a world with
// phases (river world) and one without (island); and the whole need covers at least it and the
// overview. (At 257² the real store is still over half the raw floats: the 32769² world's was an
// eighth, where zlib's worst case overestimated it 8 times.)
TEST(WorldDisk, TheEstimateIsBetweenTheRealStoreAndThreeTimesIt) {
  TempDir d("world-disk-estimate");
  struct Case {
    const char* name;
    json doc;
  };
  for (const Case& c : {Case{"river", river_world_doc()}, Case{"island", preset_doc("island")}}) {
    const Recipe r = recipe_of(c.doc, 7);
    const WorldReport rep = build_world(settings(r, 257, 257, 65, d / c.name, 2));
    ASSERT_GT(rep.store_bytes, 0u);
    EXPECT_GE(rep.estimated_store_bytes, rep.store_bytes) << c.name;
    EXPECT_LE(rep.estimated_store_bytes, 3 * rep.store_bytes) << c.name;
    EXPECT_GE(rep.estimated_bytes, rep.estimated_store_bytes + 257 * 257 * 3) << c.name;  // + the overview
  }
}

// The check keeps its promise: a folder with less free space than the estimate is refused before
// anything is written, naming the size and saying what is needed and what is free.
TEST(WorldDisk, AWorldLargerThanTheFreeSpaceIsRefusedBeforeAnythingIsWritten) {
  const Recipe r = recipe_of(river_world_doc(), 7);
  TempDir d("world-disk-refuse");
  const WorldReport rep = build_world(settings(r, 257, 257, 65, d / "a", 2));
  WorldSettings s = settings(r, 257, 257, 65, d / "b", 2);
  s.disk_free_bytes = rep.estimated_bytes - 1;
  try {
    build_world(s);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "world.size");
    EXPECT_NE(e.message().find("needs about"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find(" free"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(d.path / "b"));
  // The estimate does not depend on the thread count or on a callback (a fixed choice of windows).
  s.disk_free_bytes = 0;
  s.threads = 1;
  s.progress = [](const WorldProgress&) {};
  EXPECT_EQ(build_world(s).estimated_bytes, rep.estimated_bytes);
}

// A dry run (WorldSettings::dry_run, `relief world --dry-run`) checks and estimates as the build
// does — the same figures — and writes and removes nothing, even with --force over another world.
TEST(WorldDryRun, GivesTheBuildsEstimatesAndWritesNothing) {
  const Recipe r = recipe_of(river_world_doc(), 7);
  TempDir d("world-dry-run");
  WorldSettings s = settings(r, 257, 257, 65, d / "w", 2);
  s.dry_run = true;
  const WorldReport dry = build_world(s);
  EXPECT_TRUE(dry.dry_run);
  EXPECT_FALSE(fs::exists(d.path / "w"));
  EXPECT_EQ(dry.grid.count(), 16);
  EXPECT_GT(dry.estimated_store_bytes, 0u);
  EXPECT_GT(dry.estimated_bytes, dry.estimated_store_bytes);
  EXPECT_GT(dry.disk_free_bytes, dry.estimated_bytes);
  EXPECT_GT(dry.tile_memory_bytes, 0u);
  EXPECT_EQ(dry.tiles_built, 0);
  s.dry_run = false;
  const WorldReport built = build_world(s);
  EXPECT_FALSE(built.dry_run);
  EXPECT_EQ(dry.estimated_bytes, built.estimated_bytes);
  EXPECT_EQ(dry.estimated_store_bytes, built.estimated_store_bytes);
  EXPECT_EQ(dry.tile_memory_bytes, built.tile_memory_bytes);
  EXPECT_EQ(dry.layers, built.layers);
  EXPECT_EQ(dry.world_id, built.world_id);
  // Over the finished world: another recipe is refused as a build would refuse it, and with force
  // nothing is removed or changed.
  const auto before = store_files(d.path / "w");
  json other = river_world_doc();
  other["stages"][0]["octaves"] = 3;
  WorldSettings o = settings(recipe_of(other, 7), 257, 257, 65, d / "w", 2);
  o.dry_run = true;
  EXPECT_THROW(build_world(o), Error);
  o.force = true;
  EXPECT_TRUE(build_world(o).dry_run);
  EXPECT_EQ(store_files(d.path / "w"), before);
  // Too little disk: refused, as the build is.
  s.dry_run = true;
  s.out_dir = (d / "x");
  s.disk_free_bytes = dry.estimated_bytes - 1;
  EXPECT_THROW(build_world(s), Error);
  EXPECT_FALSE(fs::exists(d.path / "x"));
}

TEST(WorldDryRun, TheCliPrintsTheEstimatesAndBuildsNothing) {
  TempDir d("world-dry-run-cli");
  const auto r = relief::test::relief_cli("world island --size 1025 --tile 257 --seed 3 -q --dry-run -o " + (d / "w"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("world 1025x1025 in 4x4 tiles of 257 (16 tiles); layers: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("disk: about "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("memory: about "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("nothing was written (--dry-run)"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(d.path / "w"));
  // A tile size that is not 2^n+1 is still bad input (exit 2).
  EXPECT_EQ(relief::test::relief_cli("world island --size 1025 --tile 200 --dry-run -o " + (d / "w")).code, 2);
}

// The disk check counts what a world algorithm keeps besides the stores (default_world_algorithm_needs):
// hydraulic's file of the world's heights, 4 bytes per sample, in the phase's folder.
TEST(WorldDisk, HydraulicsTemporaryHeightsAreCounted) {
  json doc = preset_doc("island");
  json stages = json::array({doc["stages"][0]});
  const json without = [&] {
    json d = doc;
    d["stages"] = stages;
    return d;
  }();
  stages.push_back(json{{"stage", "hydraulic"}, {"droplets_per_km2", 100}});
  json with = doc;
  with["stages"] = stages;
  TempDir d("world-disk-scratch");
  auto dry = [&](const json& j) {
    WorldSettings s = settings(recipe_of(j, 3), 257, 257, 65, d / "w", 1);
    s.dry_run = true;
    return build_world(s).estimated_bytes;
  };
  const std::uint64_t a = dry(without), b = dry(with);
  EXPECT_GE(b, a + 4u * 257u * 257u);
  const relief::Recipe r = recipe_of(with, 3);
  const WorldGrid g = world_grid(257, 257, 65);
  const Frame f = world_frame(r, 257, 257);
  EXPECT_EQ(default_world_algorithm_needs(r.stages[1], g, f, 1).scratch_bytes, 4u * 257u * 257u);
  EXPECT_EQ(default_world_algorithm_needs(r.stages[1], g, f, 2).memory_bytes, world_hydraulic_memory_bytes(f, 65, r.stages[1].stage->params(), 2));
  EXPECT_GT(default_world_algorithm_needs(r.stages[1], g, f, 2).memory_bytes, default_world_algorithm_needs(r.stages[1], g, f, 1).memory_bytes);
  EXPECT_EQ(default_world_algorithm_needs(r.stages[0], g, f, 1).scratch_bytes, 0u);
  EXPECT_EQ(default_world_algorithm_needs(r.stages[0], g, f, 1).memory_bytes, 0u);
}
