// Stages: pointwise stages against a plain copy of their layers (the floor).
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "bench_common.hpp"
#include "relief/export.hpp"

namespace relief::cli {

void bench_stages(const BenchSettings& s, json& entries) {
  // Pointwise stages on a size² layer against a plain copy of that layer (the floor: one read
  // and one write). The target is ≤ 2× the copy. The colour stage writes a 3-channel layer and
  // is compared with a copy of a 3-channel layer of the same size. Hillshade reads the height and
  // the 3-channel albedo and writes the 1-channel 'shade' and the 3-channel colour, so its floor
  // copies the same bytes: height → shade and albedo → colour, row by row.
  const int n = s.noise_size;
  Terrain base;
  base.frame = World{n, n, 4000.0, 600.0, 0.4}.frame();
  {
    json noise_doc = {{"stage", "noise"}, {"octaves", 4}};
    auto st = find_stage("noise")->parse(noise_doc, "noise");
    Context c;
    c.seed = 1;
    st->apply(base, c);
  }
  const std::vector<float> original = base.get("height").data;
  // hillshade reads an albedo: the colour stage's output on this height field.
  Terrain coloured = base;
  {
    auto st = find_stage("color")->parse(json{{"stage", "color"}}, "color");
    Context c;
    c.seed = 1;
    st->apply(coloured, c);
  }
  const std::vector<float> original3(std::size_t(3) * n * n, 0.5f);
  // The image stage reads this height field back from an EXR at native resolution (its floor is the
  // copy), and a quarter-resolution EXR of it upsampled bicubically / bilinearly.
  const std::filesystem::path image_dir = std::filesystem::temp_directory_path() / ("relief-bench-image-" + std::to_string(::getpid()));
  std::filesystem::create_directories(image_dir);
  struct Cleanup {
    std::filesystem::path p;
    ~Cleanup() {
      std::error_code ec;
      std::filesystem::remove_all(p, ec);
    }
  } cleanup{image_dir};
  const int q = (n - 1) / 4 + 1;
  {
    std::ofstream(image_dir / "native.exr", std::ios::binary) << encode_exr_gray32(original, n, n);
    std::vector<float> small(std::size_t(q) * q);
    for (int j = 0; j < q; ++j)
      for (int i = 0; i < q; ++i) small[std::size_t(j) * q + i] = original[std::size_t(std::min(4 * j, n - 1)) * n + std::min(4 * i, n - 1)];
    std::ofstream(image_dir / "quarter.exr", std::ios::binary) << encode_exr_gray32(small, q, q);
  }
  const std::string native_exr = (image_dir / "native.exr").string(), quarter_exr = (image_dir / "quarter.exr").string();
  std::vector<float> copy_dst(original.size()), copy_dst3(original3.size());
  for (int threads : s.threads) {
    tbb::task_arena arena(threads);
    // The copies are split into the same row blocks the stages use.
    auto time_copy = [&](const std::vector<float>& src, std::vector<float>& dst, int channels, const char* name) {
      const std::size_t w = std::size_t(n) * channels;
      Sample copy = time_runs(s.runs, [&] {
        arena.execute([&] {
          parallel_rows(n, [&](int j) { std::copy_n(src.data() + j * w, w, dst.data() + j * w); });
        });
      });
      const json ce = timing_entry(name, n, n, threads, copy);
      std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   cpu %.2f ms\n", name, (std::to_string(n) + "²").c_str(), threads,
                  copy.median, copy.min, copy.max, ce["msamples_per_s"].get<double>(), copy.cpu_median);
      std::fflush(stdout);
      entries.push_back(ce);
      return copy;
    };
    const Sample copy1 = time_copy(original, copy_dst, 1, "copy (floor)");
    const Sample copy3 = time_copy(original3, copy_dst3, 3, "copy 3 channels (floor)");
    // Hillshade's floor: 1 + 3 channels in, 1 + 3 out (the copy above moves 3 + 3).
    const Sample copy4 = [&] {
      const std::size_t w = std::size_t(n);
      Sample c = time_runs(s.runs, [&] {
        arena.execute([&] {
          parallel_rows(n, [&](int j) {
            std::copy_n(original.data() + j * w, w, copy_dst.data() + j * w);
            std::copy_n(original3.data() + 3 * j * w, 3 * w, copy_dst3.data() + 3 * j * w);
          });
        });
      });
      const json ce = timing_entry("copy 1+3 channels (floor)", n, n, threads, c);
      std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   cpu %.2f ms\n", "copy 1+3 channels (floor)",
                  (std::to_string(n) + "²").c_str(), threads, c.median, c.min, c.max, ce["msamples_per_s"].get<double>(),
                  c.cpu_median);
      std::fflush(stdout);
      entries.push_back(ce);
      return c;
    }();
    const std::vector<json> cases = {
        {{"stage", "redistribute"}, {"exponent", 1.4}},
        {{"stage", "redistribute"}, {"exponent", 1.4}, {"land_only", true}},
        {{"stage", "redistribute"}, {"exponent", 2.2}, {"modifier", 1.1}},
        {{"stage", "terrace"}, {"levels", 8}},
        {{"stage", "terrace"}, {"mode", "smooth"}, {"levels", 8}},
        {{"stage", "island"}, {"distance", "square_bump"}},
        {{"stage", "island"}, {"distance", "euclidean2"}},
        {{"stage", "island"}, {"distance", "hyperboloid"}},
        {{"stage", "island"}, {"distance", "trig_product"}},
        {{"stage", "island"}, {"distance", "squircle"}},
        {{"stage", "island"}, {"distance", "circular"}, {"shaping", "subtract"}},
        {{"stage", "curve"}, {"points", json::array({json::array({0, 0}), json::array({0.4, 0.2}), json::array({0.7, 0.8}), json::array({1, 1})})}},
        {{"stage", "curve"},
         {"points", json::array({json::array({0, 0}), json::array({0.1, 0.3}), json::array({0.3, 0.35}), json::array({0.5, 0.7}),
                                 json::array({0.6, 0.6}), json::array({0.75, 0.9}), json::array({1, 1})})}},
        {{"stage", "color"}, {"mode", "bands"}},
        {{"stage", "color"}, {"mode", "gradient"}},
        {{"stage", "hillshade"}},
        {{"stage", "image"}, {"path", native_exr}},
        {{"stage", "image"}, {"path", quarter_exr}, {"filter", "bicubic"}},
        {{"stage", "image"}, {"path", quarter_exr}, {"filter", "bilinear"}},
        {{"stage", "amplify"}},
    };
    for (const json& c : cases) {
      const std::string stage = c["stage"].get<std::string>();
      const bool colour = stage == "color", shade = stage == "hillshade";
      const Sample& fl = shade ? copy4 : colour ? copy3 : copy1;
      auto st = find_stage(stage)->parse(c, "bench");
      Terrain t = stage == "hillshade" ? coloured : base;
      Context ctx;
      ctx.seed = 1;
      if (stage == "image") st->apply(t, ctx);
      // amplify reads the height it changes: the reset below restores it before every run.  // decodes the file once (cached), as a run does
      Sample ts = time_runs(
          s.runs, [&] { arena.execute([&] { st->apply(t, ctx); }); },
          [&] { std::copy(original.begin(), original.end(), t.get("height").data.begin()); });
      std::string name = stage;
      for (auto it = c.begin(); it != c.end(); ++it)
        if (it.key() == "points") name.append(" ").append(std::to_string(it.value().size())).append(" points");
        else if (it.key() == "path") name += it.value().get<std::string>() == native_exr ? " native" : " 1/4 res";
        else if (it.key() != "stage") name += " " + (it.value().is_string() ? it.value().get<std::string>() : it.key());
      const double floor = fl.median;
      json e = timing_entry(name, n, n, threads, ts);
      e["vs_copy"] = ts.median / floor;
      e["vs_copy_min"] = ts.min / fl.min;
      e["copy_channels"] = shade ? json("1+3") : json(colour ? 3 : 1);
      e["vs_copy_cpu"] = ts.cpu_median / fl.cpu_median;
      std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   %.2fx copy (min %.2fx), cpu %.2f ms = %.2fx copy%s\n",
                  name.c_str(), (std::to_string(n) + "²").c_str(), threads, ts.median, ts.min, ts.max,
                  e["msamples_per_s"].get<double>(), e["vs_copy"].get<double>(), e["vs_copy_min"].get<double>(), ts.cpu_median,
                  e["vs_copy_cpu"].get<double>(), shade ? " (1+3 channels)" : colour ? " (3 channels)" : "");
      std::fflush(stdout);
      entries.push_back(e);
    }
  }
}

}  // namespace relief::cli
