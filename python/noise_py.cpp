// relief.noise (the library's Noise over numpy arrays and grids) and the kernels behind
// relief.compat (relief/noise_classic.hpp). Argument checking that is Python-shaped (dtypes,
// shapes, broadcasting) is done in python/relief/noise.py and compat.py; these functions get
// contiguous arrays of the right dtype and release the GIL for the whole computation.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <string>

#include "py_common.hpp"
#include "relief/error.hpp"
#include "relief/noise.hpp"
#include "relief/noise_classic.hpp"
#include "relief/pipeline.hpp"

namespace py = pybind11;

namespace relief_py {
namespace {

using F32 = py::array_t<float, py::array::c_style>;
using F64 = py::array_t<double, py::array::c_style>;

relief::NoiseSettings noise_settings(const py::dict& kw) {
  relief::NoiseSettings s;
  s.basis = relief::NoiseBasis::Gradient;
  for (auto [k, v] : kw) {
    const std::string key = py::cast<std::string>(k);
    auto num = [&] {
      if (py::isinstance<py::bool_>(v) || !(py::isinstance<py::int_>(v) || py::isinstance<py::float_>(v)))
        throw relief::Error(key, "expected a number, got " + py::cast<std::string>(py::repr(v)));
      return py::cast<double>(v);
    };
    auto text = [&] {
      if (!py::isinstance<py::str>(v)) throw relief::Error(key, "expected a string, got " + py::cast<std::string>(py::repr(v)));
      return py::cast<std::string>(v);
    };
    if (key == "basis") {
      const std::string b = text();
      if (b == "gradient") s.basis = relief::NoiseBasis::Gradient;
      else if (b == "perlin") s.basis = relief::NoiseBasis::Perlin;
      else if (b == "simplex") s.basis = relief::NoiseBasis::Simplex;
      else if (b == "value") s.basis = relief::NoiseBasis::Value;
      else if (b == "cellular") s.basis = relief::NoiseBasis::Cellular;
      else throw relief::Error("basis", "expected one of gradient, perlin, simplex, value, cellular, got \"" + b + "\"");
    } else if (key == "fractal") {
      const std::string f = text();
      if (f == "fbm") s.fractal = relief::Fractal::Fbm;
      else if (f == "ridged") s.fractal = relief::Fractal::Ridged;
      else if (f == "billow") s.fractal = relief::Fractal::Billow;
      else if (f == "none") s.fractal = relief::Fractal::None;
      else throw relief::Error("fractal", "expected one of fbm, ridged, billow, none, got \"" + f + "\"");
    } else if (key == "cellular") {
      const std::string c = text();
      if (c == "f1") s.cellular = relief::CellularReturn::F1;
      else if (c == "f2") s.cellular = relief::CellularReturn::F2;
      else if (c == "f2-f1") s.cellular = relief::CellularReturn::F2MinusF1;
      else if (c == "cell_value") s.cellular = relief::CellularReturn::CellValue;
      else throw relief::Error("cellular", "expected one of f1, f2, f2-f1, cell_value, got \"" + c + "\"");
    } else if (key == "octaves") {
      if (py::isinstance<py::bool_>(v) || !py::isinstance<py::int_>(v))
        throw relief::Error("octaves", "expected an integer in 1..16, got " + py::cast<std::string>(py::repr(v)));
      const long long o = py::cast<long long>(v);
      if (o < 1 || o > relief::kMaxOctaves) throw relief::Error("octaves", "expected an integer in 1..16, got " + std::to_string(o));
      s.octaves = int(o);
    } else if (key == "seed") {
      if (py::isinstance<py::bool_>(v) || !py::isinstance<py::int_>(v) || py::reinterpret_borrow<py::int_>(v) < py::int_(0) ||
          py::reinterpret_borrow<py::int_>(v) > py::int_(relief::kMaxSeed))
        throw relief::Error("seed", "expected an integer in 0..9007199254740991, got " + py::cast<std::string>(py::repr(v)));
      s.seed = py::cast<std::uint64_t>(v);
    } else if (key == "frequency") s.frequency = num();
    else if (key == "lacunarity") s.lacunarity = num();
    else if (key == "persistence") s.persistence = num();
    else if (key == "scale_x") s.scale_x = num();
    else if (key == "scale_z") s.scale_z = num();
    else if (key == "jitter") s.jitter = num();
    else if (key == "period_x_m") s.period_x_m = num();
    else if (key == "period_z_m") s.period_z_m = num();
    else if (key == "warp_m") s.warp_m = num();
    else if (key == "warp_frequency") s.warp_frequency = num();
    else throw relief::Error(key, "unknown noise setting");
  }
  return s;
}

// Runs body(begin, end) over [0, n) in chunks on `threads` threads (0 = all), without the GIL.
template <class Body>
void parallel_chunks(std::size_t n, std::size_t grain, int threads, const Body& body) {
  py::gil_scoped_release release;
  const int t = threads > 0 ? relief::capped_threads(threads) : tbb::task_arena::automatic;
  if (threads == 1 || n <= grain) {
    body(std::size_t(0), n);
    return;
  }
  tbb::task_arena arena(t);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
  });
}

void noise_grid(const py::dict& kw, int nx, int nz, double spacing, std::int64_t ix0, std::int64_t iz0, F32 out, int threads) {
  const relief::NoiseSettings s = noise_settings(kw);
  const relief::Noise noise(s);  // validates (relief::Error naming the field)
  if (out.ndim() != 2 || out.shape(0) != nz || out.shape(1) != nx) throw relief::Error("out", "expected a float32 array of shape (nz, nx)");
  float* o = out.mutable_data();
  constexpr int kRows = 16;
  const std::size_t blocks = (std::size_t(nz) + kRows - 1) / kRows;
  parallel_chunks(blocks, 1, threads, [&](std::size_t b0, std::size_t b1) {
    double zs[kRows];
    for (std::size_t b = b0; b < b1; ++b) {
      const int j0 = int(b) * kRows, rows = std::min(kRows, nz - j0);
      for (int r = 0; r < rows; ++r) zs[r] = double(iz0 + j0 + r) * spacing;
      noise.rows(zs, rows, ix0, spacing, nx, o + std::size_t(j0) * nx, nx);
    }
  });
}

void noise_points(const py::dict& kw, F64 x, F64 z, F32 out, int threads) {
  const relief::NoiseSettings s = noise_settings(kw);
  const relief::Noise noise(s);
  const std::size_t n = std::size_t(x.size());
  if (std::size_t(z.size()) != n || std::size_t(out.size()) != n) throw relief::Error("out", "x, z and out must have the same size");
  const double* xp = x.data();
  const double* zp = z.data();
  float* o = out.mutable_data();
  parallel_chunks(n, 4096, threads, [&](std::size_t a, std::size_t b) {
    for (std::size_t k = a; k < b; ++k) o[k] = noise.at(xp[k], zp[k]);
  });
}

relief::classic::ClassicFractal fractal(int octaves, float persistence, float lacunarity) {
  relief::classic::ClassicFractal f;
  f.octaves = octaves;
  f.persistence = persistence;
  f.lacunarity = lacunarity;
  return f;
}

}  // namespace

void init_noise(py::module_& m) {
  m.def("noise_grid", &noise_grid, py::arg("settings"), py::arg("nx"), py::arg("nz"), py::arg("spacing"), py::arg("ix0"), py::arg("iz0"),
        py::arg("out"), py::arg("threads"));
  m.def("noise_points", &noise_points, py::arg("settings"), py::arg("x"), py::arg("z"), py::arg("out"), py::arg("threads"));
  m.def("noise_simd_target", &relief::noise_simd_target);

  // Scalars: the package's functions one value at a time.
  m.def("snoise2", [](float x, float y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, float base) {
    return double(relief::classic::snoise2(x, y, octaves, persistence, lacunarity, repeatx, repeaty, base));
  });
  m.def("snoise3", [](float x, float y, float z, int octaves, float persistence, float lacunarity) {
    return double(relief::classic::snoise3(x, y, z, octaves, persistence, lacunarity));
  });
  m.def("pnoise2", [](float x, float y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, int base) {
    return double(relief::classic::pnoise2(x, y, octaves, persistence, lacunarity, repeatx, repeaty, base));
  });
  m.def("pnoise3", [](float x, float y, float z, int octaves, float persistence, float lacunarity, int rx, int ry, int rz, int base) {
    return double(relief::classic::pnoise3(x, y, z, octaves, persistence, lacunarity, rx, ry, rz, base));
  });
  m.def("simplex4", &relief::classic::simplex4);

  // Arrays (float32, contiguous, same size; checked by compat.py).
  constexpr std::size_t kGrain = 8192;
  m.def("snoise2_array", [](F32 x, F32 y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, float base, F32 out,
                            int threads) {
    const float *xp = x.data(), *yp = y.data();
    float* o = out.mutable_data();
    const auto f = fractal(octaves, persistence, lacunarity);
    parallel_chunks(std::size_t(out.size()), kGrain, threads, [&](std::size_t a, std::size_t b) {
      relief::classic::snoise2(xp + a, yp + a, b - a, f, repeatx, repeaty, base, o + a);
    });
  });
  // float64 coordinates (numpy's default), rounded to float per chunk as the package rounds its
  // arguments: no full-size float32 copies.
  m.def("snoise2_array64", [](F64 x, F64 y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, float base,
                              F32 out, int threads) {
    const double *xp = x.data(), *yp = y.data();
    float* o = out.mutable_data();
    const auto f = fractal(octaves, persistence, lacunarity);
    parallel_chunks(std::size_t(out.size()), kGrain, threads, [&](std::size_t a, std::size_t b) {
      float xs[1024], ys[1024];
      for (std::size_t k0 = a; k0 < b; k0 += 1024) {
        const std::size_t m = std::min<std::size_t>(1024, b - k0);
        for (std::size_t k = 0; k < m; ++k) {
          xs[k] = float(xp[k0 + k]);
          ys[k] = float(yp[k0 + k]);
        }
        relief::classic::snoise2(xs, ys, m, f, repeatx, repeaty, base, o + k0);
      }
    });
  });
  m.def("snoise3_array", [](F32 x, F32 y, F32 z, int octaves, float persistence, float lacunarity, F32 out, int threads) {
    const float *xp = x.data(), *yp = y.data(), *zp = z.data();
    float* o = out.mutable_data();
    const auto f = fractal(octaves, persistence, lacunarity);
    parallel_chunks(std::size_t(out.size()), kGrain, threads,
                    [&](std::size_t a, std::size_t b) { relief::classic::snoise3(xp + a, yp + a, zp + a, b - a, f, o + a); });
  });
  m.def("pnoise2_array", [](F32 x, F32 y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, int base, F32 out,
                            int threads) {
    const float *xp = x.data(), *yp = y.data();
    float* o = out.mutable_data();
    const auto f = fractal(octaves, persistence, lacunarity);
    parallel_chunks(std::size_t(out.size()), kGrain, threads, [&](std::size_t a, std::size_t b) {
      relief::classic::pnoise2(xp + a, yp + a, b - a, f, repeatx, repeaty, base, o + a);
    });
  });
  m.def("pnoise3_array", [](F32 x, F32 y, F32 z, int octaves, float persistence, float lacunarity, int rx, int ry, int rz, int base,
                            F32 out, int threads) {
    const float *xp = x.data(), *yp = y.data(), *zp = z.data();
    float* o = out.mutable_data();
    const auto f = fractal(octaves, persistence, lacunarity);
    parallel_chunks(std::size_t(out.size()), kGrain, threads, [&](std::size_t a, std::size_t b) {
      relief::classic::pnoise3(xp + a, yp + a, zp + a, b - a, f, rx, ry, rz, base, o + a);
    });
  });
}

}  // namespace relief_py
