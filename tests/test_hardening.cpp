// Hostile input (issue 16): documents nested past any real recipe, bytes that are not UTF-8,
// control characters in names, and the command line's own flags. Every case must end in a
// relief::Error (exit 2 from the CLI) whose message names the field and is printable, never in a
// crash, a foreign exception or a message cut short.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "relief/recipe.hpp"
#include "support.hpp"

namespace fs = std::filesystem;
using namespace relief;

namespace {

using relief::test::slurp;

relief::test::Shell cli(const std::string& args) { return relief::test::sh(std::string(RELIEF_BINARY) + " " + args); }

std::string nested(int n) { return std::string(std::size_t(n), '[') + std::string(std::size_t(n), ']'); }

// True when `s` is well-formed UTF-8 (what nlohmann's dump() requires of every string).
bool valid_utf8(const std::string& s) {
  try {
    (void)json(s).dump();
    return true;
  } catch (const json::exception&) {
    return false;
  }
}

// The message of the relief::Error that `f` throws ("" when it throws nothing, fails otherwise).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "a foreign exception: " << typeid(e).name() << ": " << e.what();
    return "";
  }
  ADD_FAILURE() << "no error";
  return "";
}

}  // namespace

TEST(HostileJson, DeeplyNestedRecipeIsRefusedWhenParsed) {
  const std::string m = error_of([] { (void)parse_recipe_text(nested(100000)); });
  EXPECT_NE(m.find("deeper than 128 levels"), std::string::npos) << m;
  // Up to the limit a document parses (and is then refused for what it is, briefly).
  const std::string ok = error_of([] { (void)parse_recipe_text(nested(128)); });
  EXPECT_NE(ok.find("a recipe must be a JSON object, got an array [[[[["), std::string::npos) << ok;
  EXPECT_LT(ok.size(), 120u) << ok;
}

TEST(HostileJson, DeepValuesInsideARecipeAndInSetAreRefused) {
  const std::string m = error_of([] {
    (void)parse_recipe_text(R"({"stages": [{"stage": "noise", "octaves": )" + nested(100000) + "}]}");
  });
  EXPECT_NE(m.find("deeper than 128"), std::string::npos) << m;
  json doc = json::parse(R"({"stages": [{"stage": "noise"}]})");
  EXPECT_NE(error_of([&] { apply_override(doc, "stages[0].octaves=" + nested(100000)); }).find("deeper than 128"),
            std::string::npos);
  std::string path;
  for (int i = 0; i < 100000; ++i) path += "a.";
  const std::string p = error_of([&] { apply_override(doc, path + "b=1"); });
  EXPECT_NE(p.find("--set: expected a path of at most 128 levels"), std::string::npos) << p.substr(0, 200);
  EXPECT_LT(p.size(), 200u);
}

TEST(HostileJson, DescribeIsBoundedInLengthAndDepth) {
  json wide = json::array();
  for (int i = 0; i < 100000; ++i) wide.push_back(i);
  EXPECT_LE(describe(wide).size(), 80u);
  // A value built in code (not parsed) may be deeper than any parse allows: describe() walks only
  // a few levels of it (dump() would recurse a million times and overflow the stack).
  json deep = json::array();
  for (int i = 0; i < 1000000; ++i) {
    json outer = json::array();
    outer.push_back(std::move(deep));
    deep = std::move(outer);
  }
  EXPECT_LE(describe(deep).size(), 80u);
  EXPECT_EQ(describe(deep).substr(0, 12), "an array [[[");
  json obj = {{std::string(5000, 'k'), std::string(5000, 'v')}};
  EXPECT_LE(describe(obj).size(), 80u);
  EXPECT_EQ(describe(json("abc")), "\"abc\"");
  EXPECT_EQ(describe(json::array({1, 2})), "an array [1,2]");
}

TEST(HostileJson, UserPresetNestedTooDeepIsAnError) {
  relief::test::TempDir d("relief-deep-preset");
  std::ofstream(d / "deep.json") << nested(100000);
  const std::vector<std::string> dirs{d.path.string()};
  const std::string m = error_of([&] { (void)load_preset("deep", dirs); });
  bool listed = false;
  for (auto& p : list_presets(dirs)) listed = listed || p.name == "deep";
  EXPECT_NE(m.find("preset: '"), std::string::npos) << m;
  EXPECT_NE(m.find("deeper than 128"), std::string::npos) << m;
  EXPECT_TRUE(listed);
}

TEST(HostileText, InvalidUtf8InAnOverrideIsARefusalWithAPrintableMessage) {
  // The fuzzer's class (issue 16): bytes 0xC5, 0xFF, 0xBE, 0x9A in a --set value or path.
  for (const std::string set : {std::string("stages[0].octaves=ab\xff\xc5z"), std::string("stages[0].oct\xbe\x9a=3"),
                                std::string("sta\xffges[0].x=1"), std::string("name=\xc5")}) {
    json doc = json::parse(R"({"stages": [{"stage": "noise"}]})");
    const std::string m = error_of([&] {
      apply_override(doc, set);
      (void)parse_recipe(doc).to_json().dump();
    });
    EXPECT_TRUE(valid_utf8(m)) << m;
    EXPECT_FALSE(m.empty()) << set;
  }
}

TEST(HostileText, ErrorsAreValidUtf8WithoutControlCharacters) {
  const Error e(std::string("a\xff", 2), std::string("got \"x\0y\"", 9));
  EXPECT_TRUE(valid_utf8(e.what()));
  EXPECT_EQ(std::string(e.what()), "a\xEF\xBF\xBD: got \"x\\u0000y\"");
  EXPECT_EQ(e.path(), "a\xEF\xBF\xBD");
  EXPECT_EQ(quote(std::string("a\0b\"\n", 5)), "\"a\\u0000b\\\"\\n\"");
  EXPECT_EQ(quote(std::string(100, 'x'), 10), "\"" + std::string(10, 'x') + "...\"");
  // A character is never split when cut: "é" is two bytes.
  const std::string q = quote("xxxxxxxxx\xC3\xA9\xC3\xA9", 10);
  EXPECT_TRUE(valid_utf8(q)) << q;
}

TEST(HostileText, NulInAStageNameIsShownNotCutShort) {
  const std::string m = error_of([] { (void)parse_recipe(json::parse(R"({"stages": [{"stage": "no\u0000ise"}]})")); });
  EXPECT_NE(m.find("unknown stage \"no\\u0000ise\" (did you mean 'noise'?)"), std::string::npos) << m;
}

TEST(HostileText, NumbersInMessagesShowWhyTheyAreOutOfRange) {
  const std::string m = error_of([] { (void)parse_recipe(json::parse(R"({"world": {"sea_level": 1.0000001}})")); });
  EXPECT_NE(m.find("world.sea_level: expected a number in 0..1, got 1.0000001"), std::string::npos) << m;
}

TEST(HostileCli, DeeplyNestedRecipeFileExits2) {
  relief::test::TempDir d("relief-deep");
  std::ofstream(d / "d.json") << nested(100000);
  const auto r = cli("generate " + (d / "d.json") + " -q -o " + (d / "out"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("relief: error: recipe: '"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("deeper than 128 levels"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(d.path / "out"));
}

TEST(HostileCli, NulAndInvalidUtf8ReachTheTerminalEscaped) {
  relief::test::TempDir d("relief-nul");
  std::ofstream(d / "r.json") << R"({"stages": [{"stage": "no\u0000ise"}]})";
  auto r = cli("generate " + (d / "r.json") + " -q -o " + (d / "out"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("unknown stage \"no\\u0000ise\" (did you mean 'noise'?)"), std::string::npos) << r.out;
  r = cli("generate --size 33 -q -o " + (d / "out") + " --set \"$(printf 'stages[0].octaves=\\377\\305')\"");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("relief: error: stages[0].octaves: expected UTF-8 text, got \"\xEF\xBF\xBD\xEF\xBF\xBD\""),
            std::string::npos)
      << r.out;
}

TEST(FuzzReplay, AcceptsOneFileAsWellAsAFolder) {
  const std::string replay = (fs::path(RELIEF_BINARY).parent_path() / "fuzz" / "fuzz_recipe_replay").string();
  const std::string crash = std::string(RELIEF_SOURCE_DIR) + "/fuzz/corpus/recipe/crash-11b381770c8060d44bc5030197a01c0665b7257d";
  ASSERT_TRUE(fs::exists(replay));
  const auto r = relief::test::sh(replay + " " + crash + " --iterations 5");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("replay: 1 corpus inputs"), std::string::npos) << r.out;
}

namespace {
// Runs `relief ARGS` expecting exit 2 and exactly one line: `relief: error: ` + message.
void expect_cli_error(const std::string& args, const std::string& message) {
  const auto r = cli(args);
  EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
  EXPECT_EQ(r.out, "relief: error: " + message + "\n") << args;
}
}  // namespace

TEST(HostileCli, SeedsAreDecimalAndQuotedAsTyped) {
  relief::test::TempDir d("relief-seed");
  const std::string o = " -q --size 33 -o " + (d / "out");
  const std::string range = "--seed: expected an integer in 0..9007199254740991 (decimal digits), got ";
  expect_cli_error("generate --seed 0x10" + o, range + "\"0x10\"");
  expect_cli_error("generate --seed ''" + o, range + "\"\"");
  expect_cli_error("generate --seed 1.5" + o, range + "\"1.5\"");
  expect_cli_error("generate --seed 18446744073709551616" + o, range + "\"18446744073709551616\"");
  expect_cli_error("generate --seed -4" + o, range + "\"-4\"");
  // 010 is ten (not octal eight): the report records the seed used.
  ASSERT_EQ(cli("generate --seed 010" + o).code, 0);
  const json report = json::parse(slurp(d.path / "out" / "report.json"));
  EXPECT_EQ(report["seed"], 10) << report.dump().substr(0, 200);
}

TEST(HostileCli, EveryFlagErrorHasOneFormNamingTheFlag) {
  relief::test::TempDir d("relief-flags");
  const std::string o = " -q --size 33 -o " + (d / "out");
  expect_cli_error("generate -j abc" + o, "--threads: expected an integer in 0..1024, got \"abc\"");
  expect_cli_error("generate -j 2000" + o, "--threads: expected an integer in 0..1024, got \"2000\"");
  expect_cli_error("generate -q --size 33 -o ''", "--out: expected an output folder, got an empty value");
  expect_cli_error("generate -q -o x --size ''", "--size: expected N or NxM with 2..32769 samples per axis, got an empty value");
  expect_cli_error("generate --formats ''" + o, "--formats: expected comma-separated format names or 'all' (see `relief explain`), got an empty value");
  expect_cli_error("generate -o a" + o, "--out: given more than once; give it once");
  expect_cli_error("generate island --preset hills" + o, "--preset: two recipes given, \"island\" and --preset \"hills\"; give one");
  expect_cli_error("generate island hills" + o,
                   "generate: unexpected argument \"hills\" (give one recipe: a preset name or a JSON file; see relief generate --help)");
  expect_cli_error("generate --bogus" + o, "generate: unknown flag \"--bogus\" (see relief generate --help)");
  expect_cli_error("generate --godot-format r16" + o,
                   "--godot-format: applies to the godot engine: choose engine godot, or leave the format at exr");
  expect_cli_error("", "expected a command: generate, world, presets, explain, bench or studio (see relief --help)");
  expect_cli_error("studio --port 80x", "--port: expected an integer in 0..65535, got \"80x\"");
  expect_cli_error("bench --runs 0", "--runs: expected an integer in 1..1000, got \"0\"");
  EXPECT_FALSE(fs::exists(d.path / "out"));
  EXPECT_FALSE(fs::exists(d.path / "a"));
}

TEST(HostileCli, MoreThreadsThanCoresPrintNoLibraryChatter) {
  relief::test::TempDir d("relief-threads");
  const auto r = cli("generate -j 1024 -q --size 33 --seed 1 -o " + (d / "out"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out, "");
}

TEST(Explain, TextTableNeverCutsADefault) {
  const auto r = cli("explain color");
  ASSERT_EQ(r.code, 0) << r.out;
  const json table = json::parse(cli("explain color --json").out);
  json levels;
  for (auto& st : table["stages"])
    for (auto& p : st["params"])
      if (p["name"] == "levels") levels = p["default"];
  ASSERT_FALSE(levels.is_null());
  // The default's lines below the parameter's row, joined, are the whole default.
  std::istringstream in(r.out);
  std::string line, joined;
  bool on = false;
  while (std::getline(in, line)) {
    const auto text = line.find_first_not_of(' ');
    if (line.compare(text, 9, "default: ") == 0 && joined.empty()) {
      on = true;
      joined = line.substr(text + 9);
    } else if (on && line.compare(0, text, std::string(text, ' ')) == 0 && text >= 17 && line.find(':') != text + 6) {
      joined += line.substr(text);
    } else {
      on = false;
    }
    if (!joined.empty() && !on) break;
  }
  EXPECT_EQ(joined, levels.dump()) << r.out;
  EXPECT_EQ(r.out.find("default [{"), std::string::npos) << r.out;
}

TEST(Explain, NormalBitsShowsTheTwoValuesItAccepts) {
  const auto r = cli("explain");
  const auto at = r.out.find("--normal-bits");
  ASSERT_NE(at, std::string::npos);
  const std::string row = r.out.substr(at, r.out.find('\n', at) - at);
  EXPECT_NE(row.find("8|16"), std::string::npos) << row;
  EXPECT_EQ(row.find("8..16"), std::string::npos) << row;
  EXPECT_NE(cli("generate --help").out.find("8|16 bits"), std::string::npos);
}

TEST(HostileCli, FormatsAllWritesTheTilemapToo) {
  relief::test::TempDir d("relief-all");
  const auto r = cli("generate island --formats all --size 65 --seed 1 -q -o " + (d / "out"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(d.path / "out" / "tilemap.tmx") || fs::exists(d.path / "out" / "tilemap.json")) << r.out;
}

// ---- the studio's requests and headers (apps/relief/studio_request.cpp) ----------------------
#include "relief/pipeline.hpp"
#include "studio_request.hpp"

TEST(StudioRequest, DeeplyNestedBodyIsA400) {
  relief::cli::StudioSettings s;
  try {
    (void)relief::cli::parse_studio_request(relief::cli::Endpoint::Resolve, "{\"recipe\": " + nested(100000) + "}", s);
    ADD_FAILURE() << "accepted";
  } catch (const relief::cli::ApiError& e) {
    EXPECT_EQ(e.status(), 400);
    EXPECT_NE(std::string(e.what()).find("deeper than 128"), std::string::npos) << e.what();
  }
}

TEST(StudioRequest, UnknownLayerNamesAre400sKnownOnesAreNot) {
  relief::cli::StudioSettings s;
  const std::string recipe = R"({"world": {"size": 33}, "stages": [{"stage": "noise"}, {"stage": "noise", "layer": "mask"}]})";
  const auto ok = relief::cli::parse_studio_request(relief::cli::Endpoint::Generate,
                                                    R"({"recipe": )" + recipe + R"(, "layers": ["height", "albedo", "mask"]})", s);
  EXPECT_EQ(ok.layers.size(), 3u);
  try {
    (void)relief::cli::parse_studio_request(relief::cli::Endpoint::Generate, R"({"recipe": )" + recipe + R"(, "layers": ["height", "heigth"]})", s);
    ADD_FAILURE() << "accepted";
  } catch (const relief::cli::ApiError& e) {
    EXPECT_EQ(e.status(), 400);
    EXPECT_EQ(e.path(), "layers[1]");
    EXPECT_NE(e.message().find("unknown layer \"heigth\" (did you mean 'height'?)"), std::string::npos) << e.message();
  }
}

// Issue 16.2: the stage count is refused before the recipe is parsed (a bad stage past the limit
// is never reached), with the limit in the message; at the limit the recipe is parsed.
TEST(StudioRequest, MoreStagesThanTheLimitAreRefusedBeforeParsing) {
  relief::cli::StudioSettings s;
  s.max_stages = 3;
  auto body = [](int n, const char* last) {
    std::string stages;
    for (int i = 0; i < n; ++i) stages += std::string(i ? ", " : "") + R"({"stage": ")" + (i == n - 1 ? last : "noise") + "\"}";
    return R"({"recipe": {"world": {"size": 17}, "stages": [)" + stages + "]}}";
  };
  for (auto e : {relief::cli::Endpoint::Resolve, relief::cli::Endpoint::Generate, relief::cli::Endpoint::Steps}) {
    try {
      (void)relief::cli::parse_studio_request(e, body(4, "no_such_stage"), s);
      ADD_FAILURE() << "accepted";
    } catch (const relief::cli::ApiError& err) {
      EXPECT_EQ(err.status(), 400);
      EXPECT_EQ(err.path(), "stages");
      EXPECT_NE(err.message().find("at most 3 stages per recipe (--max-stages), got 4"), std::string::npos) << err.message();
    }
  }
  EXPECT_EQ(relief::cli::parse_studio_request(relief::cli::Endpoint::Generate, body(3, "noise"), s).recipe.stages.size(), 3u);
  EXPECT_EQ(relief::cli::StudioSettings{}.max_stages, 64);
}

// Issue 19: the server never opens a file a client names. An image stage (whose parsing would read
// the file's header) and a colour texture are refused before parsing, naming the field.
TEST(StudioRequest, FilesNamedByTheClientAreRefusedBeforeAnythingIsRead) {
  relief::cli::StudioSettings s;
  const std::pair<std::string, std::string> cases[] = {
      {R"({"stage": "image", "path": "/etc/passwd"})", "stages[1].path"},
      {R"({"stage": "color", "levels": [{"at": 0.5, "color": "#808080", "texture": "/etc/passwd"}]})",
       "stages[1].levels[0].texture"},
  };
  for (const auto& [stage, field] : cases) {
    const std::string body = R"({"recipe": {"world": {"size": 17}, "stages": [{"stage": "noise"}, )" + stage + "]}}";
    for (auto e : {relief::cli::Endpoint::Resolve, relief::cli::Endpoint::Generate, relief::cli::Endpoint::Export}) {
      try {
        (void)relief::cli::parse_studio_request(e, e == relief::cli::Endpoint::Export ? body.substr(0, body.size() - 1) + R"(, "format": "heightmap"})" : body, s);
        ADD_FAILURE() << "accepted " << stage;
      } catch (const relief::cli::ApiError& err) {
        EXPECT_EQ(err.status(), 400);
        EXPECT_EQ(err.path(), field);
        EXPECT_NE(err.message().find("does not read files named by a request"), std::string::npos) << err.message();
      }
    }
  }
  // An empty texture names no file.
  EXPECT_NO_THROW((void)relief::cli::parse_studio_request(
      relief::cli::Endpoint::Resolve,
      R"({"recipe": {"world": {"size": 17}, "stages": [{"stage": "noise"}, {"stage": "color", "levels": [{"at": 0.5, "color": "#808080", "texture": ""}]}]}})", s));
}

TEST(StudioRequest, WorkBudgetIsTheOptionOrAQuarterOfMemoryAtMost4GiB) {
  relief::cli::StudioSettings s;
  s.work_mib = 3;
  EXPECT_EQ(relief::cli::work_budget_bytes(s), 3u << 20);
  s.work_mib = 0;
  const std::uint64_t phys = relief::physical_memory_bytes();
  EXPECT_EQ(relief::cli::work_budget_bytes(s), phys ? std::min<std::uint64_t>(4ull << 30, phys / 4) : 4ull << 30);
}

TEST(StudioRequest, ContentDispositionCannotBeInjected) {
  using relief::cli::content_disposition;
  EXPECT_EQ(content_disposition("island-7-65-obj.zip"), "attachment; filename=\"island-7-65-obj.zip\"; filename*=UTF-8''island-7-65-obj.zip");
  const std::string evil = content_disposition("a\"b\r\nX-Evil: 1\\c/d-7.zip");
  EXPECT_EQ(evil.find_first_of("\r\n"), std::string::npos) << evil;
  EXPECT_EQ(evil, "attachment; filename=\"a_b__X-Evil__1_c_d-7.zip\"; filename*=UTF-8''a%22b__X-Evil%3A%201_c_d-7.zip");
  // Non-ASCII names keep their characters in filename* (RFC 5987); invalid bytes become U+FFFD.
  EXPECT_EQ(content_disposition("île.png"), "attachment; filename=\"__le.png\"; filename*=UTF-8''%C3%AEle.png");
  const std::string bad = content_disposition(std::string("x\xff.png"));
  EXPECT_NE(bad.find("filename*=UTF-8''x%EF%BF%BD.png"), std::string::npos) << bad;
  EXPECT_LT(content_disposition(std::string(5000, 'n')).size(), 500u);
}
