// Export: every export writer on the island preset with 2000 props, at each preset size.
#include <functional>

#include "bench_common.hpp"
#include "relief/export.hpp"
#include "relief/output.hpp"
#include "relief/random.hpp"

namespace relief::cli {

void bench_export(const BenchSettings& s, json& entries) {
  // Every export writer on the island preset with 2000 props, at each preset size, with the
  // largest thread count given: median encode time and the bytes written. The OBJ is skipped
  // above 1025² (gigabytes of text), as in the preset cases.
  const int threads = s.threads.back();
  tbb::task_arena arena(threads);
  std::printf("\n%-28s %6s %3s %10s %10s %10s %12s\n", "export case", "size", "thr", "median ms", "min ms", "max ms", "bytes");
  for (int size : s.preset_sizes) {
    json doc = preset_doc("island", size);
    RunOptions o;
    o.threads = threads;
    RunResult res = run(parse_recipe(doc), o);
    Terrain& t = res.terrain;
    const Layer& h = t.get("height");
    for (int k = 0; k < 2000; ++k) {
      const auto i = int(hash64(7, std::uint64_t(k)) % std::uint64_t(t.frame.nx));
      const auto j = int(hash64(8, std::uint64_t(k)) % std::uint64_t(t.frame.nz));
      Point p;
      p.kind = "prop";
      p.type = prop_types()[std::size_t(k) % prop_types().size()];
      p.x_m = t.frame.x_m(i);
      p.z_m = t.frame.z_m(j);
      p.y_m = t.frame.y_m(h.data[std::size_t(j) * std::size_t(t.frame.nx) + std::size_t(i)]);
      p.rotation_deg = double(k * 37 % 360);
      t.points.push_back(p);
    }
    struct Case {
      std::string name, writer;
      std::function<void(ExportOptions&)> set;
    };
    const int legal_unity = (size - 1) % 4096 == 0 || (size >= 33 && size <= 4097 && ((size - 1) & (size - 2)) == 0);
    std::vector<Case> cases = {
        {"glb", "glb", nullptr},
        {"glb lod 3 + msft_lod", "glb", [](ExportOptions& e) { e.lod_levels = 3, e.lod_msft = true; }},
        {"glb simplify 1 m", "glb", [](ExportOptions& e) { e.simplify_error_m = 1.0; }},
        {"glb lowpoly 2 m", "glb", [](ExportOptions& e) { e.simplify_error_m = 2.0, e.style = MeshStyle::Lowpoly; }},
        {"glb gpu instancing", "glb", [](ExportOptions& e) { e.instancing = Instancing::Gpu; }},
        {"fbx", "fbx", nullptr},
        {"stl", "stl", nullptr},
        {"obj", "obj", nullptr},
        {"albedo png", "albedo", nullptr},
        {"heightmap", "heightmap", nullptr},
        {"normalmap 8-bit", "normalmap", nullptr},
        {"normalmap 16-bit", "normalmap", [](ExportOptions& e) { e.normal_bits = 16; }},
        {"splat", "splat", nullptr},
        {"hillshade", "hillshade", nullptr},
        {"engine unity raw", "engine", [](ExportOptions& e) { e.engine = Engine::Unity; }},
        {"engine godot exr", "engine", [](ExportOptions& e) { e.engine = Engine::Godot; }},
    };
    for (auto& c : cases) {
      if (c.writer == "obj" && size > 1025) continue;
      if (c.writer == "engine" && !legal_unity) continue;
      WriteContext wc;
      wc.seed = res.seed;
      if (c.set) c.set(wc.options);
      std::uint64_t bytes = 0;
      Sample tm = time_runs(s.runs, [&] {
        MemoryOutput mem;
        arena.execute([&] { find_writer(c.writer)->write(t, wc, mem); });
        bytes = 0;
        for (auto& [n, b] : mem.files) bytes += b.size();
      });
      json e = timing_entry("export " + c.name, size, size, threads, tm);
      e["bytes"] = bytes;
      e["peak_memory_bytes"] = peak_rss_bytes();
      std::printf("%-28s %6s %3d %10.1f %10.1f %10.1f %12llu\n", c.name.c_str(), (std::to_string(size) + "²").c_str(), threads,
                  tm.median, tm.min, tm.max, (unsigned long long)bytes);
      std::fflush(stdout);
      entries.push_back(e);
    }
  }
}

}  // namespace relief::cli
