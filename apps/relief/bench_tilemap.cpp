// Tilemap: the tilemap stage, atlas, Tiled exports, map render and all of it end to end.
#include "bench_common.hpp"
#include "relief/output.hpp"
#include "relief/tilemap.hpp"

namespace relief::cli {

void bench_tilemap(const BenchSettings& s, json& entries) {
  // A 256×256-tile map with k = 5 types and 32 px tiles over the island preset at 1025² (4
  // height samples per tile): the stage (corner classification + tile choice), the atlas, the
  // Tiled/CSV exports, the 8192² map render with its PNG, and all of it end to end.
  json doc = preset_doc("island", 1025);
  doc["stages"].push_back({{"stage", "tilemap"},
                           {"tiles_x", 256},
                           {"tiles_z", 256},
                           {"tile_size", 32},
                           {"types", json::array({{{"at", 0.30}, {"color", "#1d4877"}, {"name", "deep water"}},
                                                  {{"at", 0.40}, {"color", "#3a7cb8"}, {"name", "water"}},
                                                  {{"at", 0.43}, {"color", "#d8c88e"}, {"name", "sand"}},
                                                  {{"at", 0.62}, {"color", "#6b9b45"}, {"name", "grass"}},
                                                  {{"at", 1.00}, {"color", "#3c6b32"}, {"name", "forest"}}})}});
  const Recipe r = parse_recipe(doc);
  const StageDef* def = find_stage("tilemap");
  const WriterDef* writer = find_writer("tilemap");
  for (int threads : s.threads) {
    RunOptions o;
    o.threads = threads;
    RunResult base = run(r, o);  // every stage, once, for the per-part timings below
    const TileMap& m = *base.terrain.tilemap;
    tbb::task_arena arena(threads);
    auto stage = def->parse(doc["stages"].back(), "stages[5]");
    auto row = [&](const std::string& name, const Sample& t) {
      json e = timing_entry(name, 256, 256, threads, t);  // msamples_per_s: tiles per µs
      e["peak_memory_bytes"] = peak_rss_bytes();
      print_row(e);
      entries.push_back(e);
    };
    row("tilemap stage k5", time_runs(s.runs, [&] {
          arena.execute([&] {
            Context ctx;
            ctx.seed = 1;
            ctx.stage_index = 5;
            stage->apply(base.terrain, ctx);
          });
        }));
    RgbImage atlas;
    row("tilemap atlas k5 32px", time_runs(s.runs, [&] {
          arena.execute([&] {
            atlas = render_atlas(m.style);
            encode_png_rgb8(atlas.rgb.data(), atlas.width, atlas.height);
          });
        }));
    row("tilemap tsx+tmx+tmj+csv", time_runs(s.runs, [&] {
          encode_tsx(m.style);
          encode_tmx(m);
          encode_tmj(m);
          encode_tile_csv(m);
        }));
    row("tilemap render 8192² + png", time_runs(s.runs, [&] {
          arena.execute([&] {
            const RgbImage img = render_map(m, atlas);
            encode_png_rgb8(img.rgb.data(), img.width, img.height);
          });
        }));
    row("tilemap end to end", time_runs(s.runs, [&] {
          RunResult res = run(r, o);
          MemoryOutput mem;
          WriteContext wc;
          wc.seed = res.seed;
          arena.execute([&] { writer->write(res.terrain, wc, mem); });
        }));
  }
}

}  // namespace relief::cli
