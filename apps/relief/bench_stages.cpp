// Stages: pointwise stages against a plain copy of their layers (the floor).
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "bench_common.hpp"
#include "relief/export.hpp"

namespace relief::cli {

namespace {

// Issue 19's fixed sizes, whatever --noise-size says: (a) bicubic (and bilinear) resampling of a
// 1025² image to 4097² (4 samples per pixel), in output samples per second; (b) amplify at 4097²
// from a 257² sketch (the image stage reading the sketch, then amplify), as time and as a ratio to
// a plain copy of the 4097² layer measured in the same run; also the image stage reading a 4097²
// image at native resolution, against the same copy (target ≤ 2×).
constexpr int kBig = 4097, kInput = 1025, kSketch = 257;

struct ImageInputs {
  std::filesystem::path dir;
  std::string input, sketch, native;
  std::vector<float> big;  // the 4097² layer the copy moves
};

// A size² noise field (4 octaves, seed 1) over a 4000 m world.
std::vector<float> noise_field(int size) {
  Terrain t;
  t.frame = World{size, size, 4000.0, 600.0, 0.4}.frame();
  auto st = find_stage("noise")->parse(json{{"stage", "noise"}, {"octaves", 4}}, "noise");
  Context c;
  c.seed = 1;
  st->apply(t, c);
  return t.get("height").data;
}

// The inputs' folder once made (removed at exit by the object below; nothing to do otherwise).
std::filesystem::path made_dir;

const ImageInputs& image_inputs() {
  static ImageInputs* in = [] {
    auto* x = new ImageInputs;
    x->dir = std::filesystem::temp_directory_path() / ("relief-bench-sizes-" + std::to_string(::getpid()));
    made_dir = x->dir;
    std::filesystem::create_directories(x->dir);
    x->input = (x->dir / "input_1025.exr").string();
    x->sketch = (x->dir / "sketch_257.exr").string();
    x->native = (x->dir / "native_4097.exr").string();
    std::ofstream(x->input, std::ios::binary) << encode_exr_gray32(noise_field(kInput), kInput, kInput);
    std::ofstream(x->sketch, std::ios::binary) << encode_exr_gray32(noise_field(kSketch), kSketch, kSketch);
    x->big = noise_field(kBig);
    std::ofstream(x->native, std::ios::binary) << encode_exr_gray32(x->big, kBig, kBig);
    return x;
  }();
  return *in;
}

// Removes the inputs' folder at exit (the inputs above are made once and kept for every thread count).
struct ImageInputsCleanup {
  ~ImageInputsCleanup() {
    std::error_code ec;
    if (!made_dir.empty()) std::filesystem::remove_all(made_dir, ec);
  }
} image_inputs_cleanup;

void print_vs_copy(const json& e, const Sample& ts, const char* note) {
  std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   %.2fx copy (min %.2fx), cpu %.2f ms = %.2fx copy%s\n",
              e["name"].get<std::string>().c_str(), (std::to_string(kBig) + "²").c_str(), e["threads"].get<int>(), ts.median, ts.min,
              ts.max, e["msamples_per_s"].get<double>(), e["vs_copy"].get<double>(), e["vs_copy_min"].get<double>(), ts.cpu_median,
              e["vs_copy_cpu"].get<double>(), note);
  std::fflush(stdout);
}

void bench_image_sizes(const BenchSettings& s, int threads, tbb::task_arena& arena, json& entries) {
  const ImageInputs& in = image_inputs();
  Terrain base;
  base.frame = World{kBig, kBig, 4000.0, 600.0, 0.4}.frame();
  base.layer("height", 1).data = in.big;
  // The floor: a plain copy of the 4097² layer, in the same row blocks the stages use.
  std::vector<float> dst(in.big.size());
  const std::size_t w = std::size_t(kBig);
  const Sample copy = time_runs(s.runs, [&] {
    arena.execute([&] { parallel_rows(kBig, [&](int j) { std::copy_n(in.big.data() + j * w, w, dst.data() + j * w); }); });
  });
  {
    const json ce = timing_entry("copy (floor)", kBig, kBig, threads, copy);
    std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   cpu %.2f ms\n", "copy (floor)", (std::to_string(kBig) + "²").c_str(), threads,
                copy.median, copy.min, copy.max, ce["msamples_per_s"].get<double>(), copy.cpu_median);
    std::fflush(stdout);
    entries.push_back(ce);
  }
  auto with_copy = [&](json e, const Sample& ts) {
    e["vs_copy"] = ts.median / copy.median;
    e["vs_copy_min"] = ts.min / copy.min;
    e["vs_copy_cpu"] = ts.cpu_median / copy.cpu_median;
    e["copy_channels"] = 1;
    return e;
  };
  auto stage_of = [](const json& doc) { return find_stage(doc["stage"].get<std::string>())->parse(doc, "bench"); };
  Context ctx;
  ctx.seed = 1;
  // The image stage at native resolution (4097² image into the 4097² layer).
  {
    auto st = stage_of({{"stage", "image"}, {"path", in.native}});
    Terrain t = base;
    const Sample ts = time_runs(s.runs, [&] { arena.execute([&] { st->apply(t, ctx); }); });
    json e = with_copy(timing_entry("image native 4097", kBig, kBig, threads, ts), ts);
    e["target_vs_copy"] = 2.0;
    e["missed"] = ts.median / copy.median > 2.0;
    print_vs_copy(e, ts, ts.median / copy.median > 2.0 ? "  MISSED (target <= 2x copy)" : "  (target <= 2x copy: met)");
    entries.push_back(e);
  }
  // (a) 1025² → 4097², samples per second of output.
  for (const char* filter : {"bicubic", "bilinear"}) {
    auto st = stage_of({{"stage", "image"}, {"path", in.input}, {"filter", filter}});
    Terrain t = base;
    const Sample ts = time_runs(s.runs, [&] { arena.execute([&] { st->apply(t, ctx); }); });
    json e = with_copy(timing_entry(std::string("image 1025->4097 ") + filter, kBig, kBig, threads, ts), ts);
    e["input_size"] = json::array({kInput, kInput});
    print_vs_copy(e, ts, "");
    entries.push_back(e);
  }
  // (b) amplify 4097² from a 257² sketch: first octave at two sketch pixels, 5 octaves (down to
  // about two samples).
  {
    const double pixel_m = 4000.0 / (kSketch - 1);
    auto image = stage_of({{"stage", "image"}, {"path", in.sketch}});
    auto amplify = stage_of({{"stage", "amplify"}, {"wavelength_m", 2 * pixel_m}, {"octaves", 5}});
    Terrain t = base;
    const Sample both = time_runs(s.runs, [&] {
      arena.execute([&] {
        image->apply(t, ctx);
        amplify->apply(t, ctx);
      });
    });
    json e = with_copy(timing_entry("image 257->4097 + amplify", kBig, kBig, threads, both), both);
    e["input_size"] = json::array({kSketch, kSketch});
    print_vs_copy(e, both, "");
    entries.push_back(e);
    // amplify alone on the resampled sketch (restored before every run, untimed).
    image->apply(t, ctx);
    const std::vector<float> sketch = t.get("height").data;
    const Sample amp = time_runs(
        s.runs, [&] { arena.execute([&] { amplify->apply(t, ctx); }); },
        [&] { std::copy(sketch.begin(), sketch.end(), t.get("height").data.begin()); });
    json a = with_copy(timing_entry("amplify (257 sketch) alone", kBig, kBig, threads, amp), amp);
    print_vs_copy(a, amp, "");
    entries.push_back(a);
  }
}

}  // namespace

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
      // The image stage at native resolution: issue 19's target is ≤ 2× the copy of its layer.
      const bool native = stage == "image" && c["path"] == native_exr;
      if (native) {
        e["target_vs_copy"] = 2.0;
        e["missed"] = ts.median / floor > 2.0;
      }
      std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   %.2fx copy (min %.2fx), cpu %.2f ms = %.2fx copy%s%s\n",
                  name.c_str(), (std::to_string(n) + "²").c_str(), threads, ts.median, ts.min, ts.max,
                  e["msamples_per_s"].get<double>(), e["vs_copy"].get<double>(), e["vs_copy_min"].get<double>(), ts.cpu_median,
                  e["vs_copy_cpu"].get<double>(), shade ? " (1+3 channels)" : colour ? " (3 channels)" : "",
                  native ? (ts.median / floor > 2.0 ? "  MISSED (target <= 2x copy)" : "  (target <= 2x copy: met)") : "");
      std::fflush(stdout);
      entries.push_back(e);
    }
    bench_image_sizes(s, threads, arena, entries);
  }
}

}  // namespace relief::cli
