// DEM processing: the slope and hillshade stages against GDAL's own (gdaldem slope / hillshade,
// Horn's kernel, run in process through GDALDEMProcessing on in-memory datasets), measured in the
// same run on the same heights in metres, against a plain copy of a layer (the floor), and against
// their own kernel (the stage writing into output layers that already exist). Issue 17's targets
// at 1 thread, marked MISSED when not met: slope stage ≤ 1.0× GDAL's slope; hillshade stage ≤ 1.5×
// its kernel. Each case also times its output layers' creation alone (the OS's first touch of new
// memory plus the zero fill of a new std::vector<float>) and the zero fill alone, in the same run,
// so that the stage's time beyond its kernel is accounted for.
//
// GDAL is loaded with dlopen, as the library loads it (src/gdal_dl.hpp): linking it would add its
// hundred shared libraries to every `relief` process. Without GDAL the peer columns are empty.
#include <dlfcn.h>

#include "bench_common.hpp"

#if RELIEF_HAVE_GDAL
#include <gdal.h>
#include <gdal_utils.h>
#endif

namespace relief::cli {

namespace {

#if RELIEF_HAVE_GDAL
// The few GDAL functions the peer needs, with GDAL's own types.
struct GdalDem {
#define RELIEF_GDAL_FN(name) decltype(&::name) name = nullptr;
  RELIEF_GDAL_FN(GDALAllRegister)
  RELIEF_GDAL_FN(GDALGetDriverByName)
  RELIEF_GDAL_FN(GDALCreate)
  RELIEF_GDAL_FN(GDALClose)
  RELIEF_GDAL_FN(GDALSetGeoTransform)
  RELIEF_GDAL_FN(GDALGetRasterBand)
  RELIEF_GDAL_FN(GDALRasterIO)
  RELIEF_GDAL_FN(GDALDEMProcessingOptionsNew)
  RELIEF_GDAL_FN(GDALDEMProcessingOptionsFree)
  RELIEF_GDAL_FN(GDALDEMProcessing)
#undef RELIEF_GDAL_FN
};

const GdalDem* gdal_dem() {
  static const GdalDem* g = []() -> const GdalDem* {
    void* h = dlopen(RELIEF_GDAL_SONAME, RTLD_NOW | RTLD_LOCAL);
    if (!h) return nullptr;
    auto* d = new GdalDem;
    bool ok = true;
    auto load = [&](auto& fn, const char* name) {
      fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(dlsym(h, name));
      ok = ok && fn;
    };
    load(d->GDALAllRegister, "GDALAllRegister");
    load(d->GDALGetDriverByName, "GDALGetDriverByName");
    load(d->GDALCreate, "GDALCreate");
    load(d->GDALClose, "GDALClose");
    load(d->GDALSetGeoTransform, "GDALSetGeoTransform");
    load(d->GDALGetRasterBand, "GDALGetRasterBand");
    load(d->GDALRasterIO, "GDALRasterIO");
    load(d->GDALDEMProcessingOptionsNew, "GDALDEMProcessingOptionsNew");
    load(d->GDALDEMProcessingOptionsFree, "GDALDEMProcessingOptionsFree");
    load(d->GDALDEMProcessing, "GDALDEMProcessing");
    if (!ok) return nullptr;
    d->GDALAllRegister();
    return d;
  }();
  return g;
}

// An in-memory Float32 dataset of the heights in metres, `cell` metres per sample.
GDALDatasetH mem_dataset(const GdalDem& g, const std::vector<float>& metres, int n, double cell) {
  GDALDriverH mem = g.GDALGetDriverByName("MEM");
  GDALDatasetH ds = g.GDALCreate(mem, "", n, n, 1, GDT_Float32, nullptr);
  double gt[6] = {0, cell, 0, 0, 0, -cell};
  g.GDALSetGeoTransform(ds, gt);
  if (g.GDALRasterIO(g.GDALGetRasterBand(ds, 1), GF_Write, 0, 0, n, n, const_cast<float*>(metres.data()), n, n,
                       GDT_Float32, 0, 0) != CE_None)
    throw Error("bench", "GDAL could not write the heights into its in-memory dataset");
  return ds;
}

// gdaldem PROCESSING (Horn's kernel, GDAL's default) of `src` into a new in-memory dataset.
// GDAL's DEM processing runs on one thread whatever the arena (GDAL_NUM_THREADS does not apply).
bool gdal_dem_run(const GdalDem& g, GDALDatasetH src, const char* processing) {
  char* argv[] = {const_cast<char*>("-of"), const_cast<char*>("MEM"), const_cast<char*>("-compute_edges"), nullptr};
  GDALDEMProcessingOptions* o = g.GDALDEMProcessingOptionsNew(argv, nullptr);
  int usage_error = 0;
  GDALDatasetH out = g.GDALDEMProcessing("", src, processing, nullptr, o, &usage_error);
  g.GDALDEMProcessingOptionsFree(o);
  if (!out) return false;
  g.GDALClose(out);
  return true;
}
#endif

}  // namespace

void bench_dem(const BenchSettings& s, json& entries) {
  // The island preset's fBm relief at noise_size + 1 samples (4097² by default), 4 km wide.
  const int n = s.noise_size + 1;
  json doc = preset_doc("island", n);
  doc["stages"] = json::array({doc["stages"][0], doc["stages"][1]});
  const Terrain base = run(parse_recipe(doc), RunOptions{}).terrain;
  const Frame& f = base.frame;
  std::vector<float> metres(base.get("height").data.size());
  for (std::size_t k = 0; k < metres.size(); ++k) metres[k] = float(f.y_m(base.get("height").data[k]));
  // Hillshade reads an albedo: the colour stage's output.
  Terrain coloured = base;
  {
    Context c;
    find_stage("color")->parse(json{{"stage", "color"}}, "bench")->apply(coloured, c);
  }
  for (int threads : s.threads) {
    tbb::task_arena arena(threads);
    std::vector<float> copy_to(metres.size());
    const Sample copy = time_runs(s.runs, [&] { arena.execute([&] { std::copy(metres.begin(), metres.end(), copy_to.begin()); }); });
    struct Case {
      const char* stage;
      const char* gdal;
      const Terrain* input;
      std::vector<std::string> outputs;  // the layers the stage writes (removed before each run: fresh, as GDAL's)
    };
    const Case cases[] = {{"slope", "slope", &base, {"slope", "slope_deg"}},
                          {"hillshade", "hillshade", &coloured, {"shade", "color"}}};
    double hillshade_kernel_ms = 0;
    for (const Case& c : cases) {
      auto st = find_stage(c.stage)->parse(json{{"stage", c.stage}}, "bench");
      Terrain t, fresh;
      Context ctx;
      // The stage as a recipe runs it: its output layers are new. In the steady state of repeated
      // runs in one process (what the median measures) their buffers come from the process-wide
      // cache (relief/terrain.hpp, kLayerCacheMinBytes), which the erased layers of the run before
      // went to; a first run in a fresh cache (released before each run) allocates and first touches them.
      const Sample ours = time_runs(
          s.runs, [&] { arena.execute([&] { st->apply(t, ctx); }); },
          [&] {
            t = *c.input;
            for (auto& o : c.outputs) t.layers.erase(o);
          });
      const Sample first = time_runs(
          s.runs, [&] { arena.execute([&] { st->apply(t, ctx); }); },
          [&] {
            t = *c.input;
            for (auto& o : c.outputs) t.layers.erase(o);
            release_cached_buffers();
          });
      // Its kernel: the same stage again on the same terrain, writing into the output layers of
      // the run before (already allocated and mapped), as a regenerating run with recycled buffers.
      const Sample kernel = time_runs(s.runs, [&] { arena.execute([&] { st->apply(t, ctx); }); });
      const bool slope = std::string(c.stage) == "slope";
      if (!slope) hillshade_kernel_ms = kernel.median;
      // Where the stage's time beyond its kernel goes: creating its output layers alone on a
      // terrain without them (Terrain::layer_for_overwrite: the OS's first touch of new memory,
      // then the zero fill every new std::vector<float> gets), and that zero fill alone, over the
      // same layers once they are mapped. First touch ≈ the difference.
      const Sample alloc = time_runs(
          s.runs,
          [&] {
            arena.execute([&] {
              for (auto& o : c.outputs) fresh.layer_for_overwrite(o, t.get(o).channels);
            });
          },
          [&] {
            fresh = Terrain();
            fresh.frame = f;
            release_cached_buffers();  // new memory, not the buffers the layers just gave back
          });
      const Sample zero = time_runs(s.runs, [&] {
        arena.execute([&] {
          for (auto& o : c.outputs) std::fill(t.get(o).data.begin(), t.get(o).data.end(), 0.0f);
        });
      });
      fresh = Terrain();
      json e = timing_entry(std::string(c.stage) + " stage", n, n, threads, ours);
      e["outputs"] = {{"alloc_median_ms", alloc.median},
                      {"zero_fill_median_ms", zero.median},
                      {"first_touch_ms", alloc.median - zero.median},
                      {"stage_minus_kernel_ms", ours.median - kernel.median}};
      e["vs_copy"] = ours.median / copy.median;
      e["vs_copy_cpu"] = ours.cpu_median / copy.cpu_median;
      e["kernel"] = {{"median_ms", kernel.median}, {"min_ms", kernel.min}, {"max_ms", kernel.max}, {"cpu_median_ms", kernel.cpu_median}};
      e["vs_kernel"] = ours.median / kernel.median;
      e["vs_kernel_cpu"] = ours.cpu_median / kernel.cpu_median;
      const bool cache_on = buffer_cache_limit() > 0;
      e["buffers"] = cache_on ? "steady state: output buffers recycled by the process-wide cache"
                              : "process-wide cache off (RELIEF_BUFFER_CACHE_MB=0): outputs allocated";
      e["first_run"] = {{"median_ms", first.median},
                        {"min_ms", first.min},
                        {"max_ms", first.max},
                        {"vs_kernel", first.median / kernel.median},
                        {"buffers", "fresh cache (released before each run): outputs allocated"}};
      bool missed = false;
      if (!slope && threads == 1) {  // issue 17: the hillshade stage ≤ 1.5× its kernel
        e["target_vs_kernel"] = 1.5;
        missed = missed || ours.median / kernel.median > 1.5;
      }
      double peer_ms = 0, peer_cpu = 0;
#if RELIEF_HAVE_GDAL
      if (const GdalDem* g = gdal_dem()) {
        GDALDatasetH src = mem_dataset(*g, metres, n, f.cell_m());
        bool ok = true;
        const Sample peer = time_runs(s.runs, [&] { ok = ok && gdal_dem_run(*g, src, c.gdal); });
        g->GDALClose(src);
        if (ok) {
          peer_ms = peer.median, peer_cpu = peer.cpu_median;
          // As the noise cases' libnoise peer: the peer's figures, and ratio = our throughput / the peer's.
          e["peer"] = {{"name", std::string("GDAL gdaldem ") + c.gdal + " (Horn, in process, 1 thread)"},
                       {"median_ms", peer.median},
                       {"cpu_median_ms", peer.cpu_median},
                       {"msamples_per_s", double(n) * double(n) / (peer.median * 1e3)}};
          e["ratio"] = peer.median / ours.median;
          e["vs_peer"] = ours.median / peer.median;  // time ratio (target for slope: ≤ 1.0 at 1 thread)
          e["vs_peer_cpu"] = ours.cpu_median / peer.cpu_median;
          e["kernel_vs_peer"] = kernel.median / peer.median;
          if (slope && threads == 1) {  // issue 17: the slope stage ≤ 1.0× GDAL's slope
            e["target_vs_peer"] = 1.0;
            missed = missed || ours.median / peer.median > 1.0;
          }
        }
      }
#endif
      if (e.contains("target_vs_peer") || e.contains("target_vs_kernel")) e["missed"] = missed;
      std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f   %.2fx copy, cpu %.2fx copy; kernel %.2f ms: %.2fx kernel",
                  (std::string(c.stage) + " stage").c_str(), (std::to_string(n) + "²").c_str(), threads, ours.median, ours.min,
                  ours.max, e["vs_copy"].get<double>(), e["vs_copy_cpu"].get<double>(), kernel.median,
                  ours.median / kernel.median);
      if (!slope && threads == 1) std::printf(" (target ≤ 1.5x%s)", ours.median / kernel.median > 1.5 ? ": MISSED" : ": met");
      std::printf(" [%s]; first run (fresh cache) %.2f ms: %.2fx kernel", cache_on ? "steady state, cached buffers" : "cache off",
                  first.median, first.median / kernel.median);
      std::printf("; outputs' allocation %.2f ms (first touch %.2f, zero fill %.2f)", alloc.median, alloc.median - zero.median,
                  zero.median);
      if (peer_ms > 0) {
        const double ratio = ours.median / peer_ms;
        std::printf("; GDAL %.2f ms (cpu %.2f): %.2fx GDAL (cpu %.2fx), kernel %.2fx GDAL", peer_ms, peer_cpu, ratio,
                    ours.cpu_median / peer_cpu, kernel.median / peer_ms);
        if (slope && threads == 1) std::printf(" (target ≤ 1.0x%s)", ratio > 1.0 ? ": MISSED" : ": met");
      }
      std::printf("\n");
      std::fflush(stdout);
      entries.push_back(e);
    }
    // The hillshade stage inside a recipe: the island preset (noise, island, redistribute, color,
    // hillshade) run whole at the same size, the stage's own time taken from the run's timings;
    // as repeated runs (the steady state: each run's layers take the buffers the run before gave
    // the process-wide cache), as first runs (the cache released before each: every layer
    // allocated), and regenerating (RunOptions::recycle: the previous result's buffers reused, as
    // the studio does). Against the kernel measured above.
    {
      const Recipe r = parse_recipe(preset_doc("island", n));
      std::size_t at = r.stages.size();
      for (std::size_t k = 0; k < r.stages.size(); ++k)
        if (r.stages[k].def && r.stages[k].def->name == "hillshade") at = k;
      for (bool recycle : {false, true}) {
        if (at == r.stages.size() || hillshade_kernel_ms <= 0) break;
        RunOptions o;
        o.threads = threads;
        Terrain previous;
        std::vector<double> stage_ms;
        const Sample whole = time_runs(s.runs, [&] {
          if (recycle) o.recycle = &previous;
          RunResult res = run(r, o);
          if (at < res.timings.size()) stage_ms.push_back(res.timings[at].ms);
          if (recycle) previous = std::move(res.terrain);
        });
        stage_ms.erase(stage_ms.begin());  // the warm-up run
        const double ms = median_of(stage_ms);
        // Without RunOptions::recycle, the runs after the first take their layers' buffers from the
        // process-wide cache (the steady state above); a first run in a fresh cache allocates them.
        std::vector<double> first_ms;
        Sample first_whole{};
        if (!recycle) {
          first_whole = time_runs(
              s.runs,
              [&] {
                RunResult res = run(r, o);
                if (at < res.timings.size()) first_ms.push_back(res.timings[at].ms);
              },
              [] { release_cached_buffers(); });
          first_ms.erase(first_ms.begin());
        }
        const std::string name = recycle ? "hillshade in island, recycled" : "hillshade in island recipe";
        json e = timing_entry(name, n, n, threads, Sample{ms, *std::min_element(stage_ms.begin(), stage_ms.end()),
                                                          *std::max_element(stage_ms.begin(), stage_ms.end()), 0});
        e["recipe_median_ms"] = whole.median;
        e["kernel_median_ms"] = hillshade_kernel_ms;
        e["vs_kernel"] = ms / hillshade_kernel_ms;
        e["buffers"] = recycle                      ? "RunOptions::recycle: the previous result's buffers"
                       : buffer_cache_limit() > 0 ? "steady state: layer buffers recycled by the process-wide cache"
                                                  : "process-wide cache off (RELIEF_BUFFER_CACHE_MB=0): every layer allocated";
        if (!recycle && !first_ms.empty()) {
          const double fm = median_of(first_ms);
          e["first_run"] = {{"median_ms", fm},
                            {"min_ms", *std::min_element(first_ms.begin(), first_ms.end())},
                            {"max_ms", *std::max_element(first_ms.begin(), first_ms.end())},
                            {"vs_kernel", fm / hillshade_kernel_ms},
                            {"recipe_median_ms", first_whole.median},
                            {"buffers", "fresh cache (released before each run): every layer allocated"}};
        }
        const bool target = threads == 1 && !recycle;
        if (target) {
          e["target_vs_kernel"] = 1.5;
          e["missed"] = ms / hillshade_kernel_ms > 1.5;
        }
        std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f   %.2fx kernel (%.2f ms)%s; whole recipe %.0f ms [%s]\n", name.c_str(),
                    (std::to_string(n) + "²").c_str(), threads, ms, e["min_ms"].get<double>(), e["max_ms"].get<double>(),
                    ms / hillshade_kernel_ms, hillshade_kernel_ms,
                    target ? (ms / hillshade_kernel_ms > 1.5 ? " (target ≤ 1.5x: MISSED)" : " (target ≤ 1.5x: met)") : "",
                    whole.median, recycle ? "recycled by RunOptions::recycle" : buffer_cache_limit() > 0 ? "steady state, cached buffers" : "cache off");
        if (e.contains("first_run"))
          std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f   %.2fx kernel (first run, fresh cache: every layer allocated); whole recipe %.0f ms\n",
                      "  same, first run", (std::to_string(n) + "²").c_str(), threads, e["first_run"]["median_ms"].get<double>(),
                      e["first_run"]["min_ms"].get<double>(), e["first_run"]["max_ms"].get<double>(),
                      e["first_run"]["vs_kernel"].get<double>(), first_whole.median);
        std::fflush(stdout);
        entries.push_back(e);
      }
    }
  }
}

}  // namespace relief::cli
