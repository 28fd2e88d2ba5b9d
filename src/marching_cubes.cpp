// relief::mesh_density: marching cubes over a DensityBlock (contract in include/relief/volume_mesh.hpp).
//
// Papers: W. E. Lorensen, H. E. Cline, "Marching cubes: A high resolution 3D surface construction
// algorithm", SIGGRAPH 1987 (the method); C. Montani, R. Scateni, R. Scopigno, "A modified look-up
// table for implicit disambiguation of Marching Cubes", The Visual Computer 10(6), 1994 (ambiguous
// faces resolved from the corner signs alone, consistently for both cubes of a face; our table is
// derived from that rule at compile time in marching_cubes_tables.hpp).
//
// How it goes fast (most cells of a cave field have no sign change):
//   1. sign bits: one bit per sample (solid = density > 0), 64 per word, per sample row;
//   2. crossed edges per row as word operations (x: s ^ s >> 1, z: row k ^ row k + 1, y: layer j ^
//      layer j + 1), with a running vertex count per word: the vertex of a crossed edge is its layer's
//      first vertex + the word's base + the popcount of the crossed bits below it (no per-edge cache);
//   3. vertices (interpolation and normals) only for crossed edges, written to their final place;
//   4. active cells per row pair as word operations (some corner solid and not all), visited with
//      count-trailing-zeros; the case table gives the triangles' edges, step 2 their vertex indices.
// Steps 2-4 run over sample layers in parallel on the current oneTBB arena; each layer's output has a
// fixed place (vertex offsets from a prefix sum, triangle lists concatenated in layer order), so the
// bytes are the same for any thread count.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

#include "marching_cubes_tables.hpp"
#include "relief/error.hpp"
#include "relief/volume_mesh.hpp"

namespace relief {

namespace {

using u64 = std::uint64_t;

// Bits [lo, hi] (inclusive, 0 ≤ lo ≤ hi) set in word w of a row mask.
u64 range_word(int w, int lo, int hi) {
  const int b0 = w * 64, b1 = b0 + 63;
  if (hi < b0 || lo > b1) return 0;
  const int a = std::max(lo, b0) - b0, z = std::min(hi, b1) - b0;
  const u64 upper = z == 63 ? ~u64(0) : (u64(1) << (z + 1)) - 1;
  return upper & ~((u64(1) << a) - 1);
}

// Bits i and i + 1 of a padded row mask (the word after the last is 0).
inline unsigned two_bits(const u64* row, int i) {
  const int w = i >> 6, r = i & 63;
  return unsigned(((row[w] >> r) | (row[w + 1] << 1 << (63 - r))) & 3u);
}

inline int rank_below(u64 word, int r) { return std::popcount(word & ((u64(1) << r) - 1)); }

struct Work {
  const DensityBlock& b;
  int a;       // apron
  int W;       // words per row, the last one a zero pad
  // Per (sample layer, row): sign bits, crossed x / z / y edges and their per-word vertex bases (local to
  // the layer). Index: (j * nz + k) * W + w.
  std::vector<u64> sign, xc, zc, yc;
  std::vector<std::uint32_t> bx, bz, by;
  std::vector<std::uint32_t> layer_first;  // per sample layer j: index of its first vertex
  std::vector<u64> edge_range, sample_range, cell_range;  // per word: bits [a, nx-2-a], [a, nx-1-a], [a, nx-2-a]

  std::size_t row(int j, int k) const { return (std::size_t(j) * b.nz + k) * W; }
};

[[noreturn]] void too_small(const char* field, int n, int apron) {
  throw Error(field, "expected at least 2·apron + 2 = " + std::to_string(2 * apron + 2) +
                         " samples (one meshed cell inside the apron of " + std::to_string(apron) + "), got " +
                         std::to_string(n));
}

}  // namespace

VolumeMesh mesh_density(const DensityBlock& b, int apron) {
  if (apron < 1) throw Error("apron", "expected an apron of at least 1 sample layer, got " + std::to_string(apron));
  if (b.nx < 2 * apron + 2) too_small("nx", b.nx, apron);
  if (b.ny < 2 * apron + 2) too_small("ny", b.ny, apron);
  if (b.nz < 2 * apron + 2) too_small("nz", b.nz, apron);
  if (!(std::isfinite(b.cell_m) && b.cell_m > 0))
    throw Error("cell_m", "expected a finite cell size > 0 metres, got " + std::to_string(b.cell_m));
  const std::size_t samples = std::size_t(b.nx) * std::size_t(b.ny) * std::size_t(b.nz);
  if (b.d.size() != samples)
    throw Error("d", "expected nx·ny·nz = " + std::to_string(samples) + " density samples, got " +
                         std::to_string(b.d.size()));
  if (samples >= (std::size_t(1) << 30))
    throw Error("d", "expected fewer than 2^30 samples per block (32-bit vertex indices), got " + std::to_string(samples));

  const int nx = b.nx, ny = b.ny, nz = b.nz, a = apron;
  const int jlo = a, jhi = ny - 1 - a, klo = a, khi = nz - 1 - a;  // meshed sample range (inclusive)
  Work wk{b, a, (nx + 63) / 64 + 1, {}, {}, {}, {}, {}, {}, {}, {}, {}, {}, {}};
  const int W = wk.W;
  const std::size_t rows = std::size_t(ny) * nz * W;
  wk.sign.assign(rows, 0);
  wk.xc.assign(rows, 0);
  wk.zc.assign(rows, 0);
  wk.yc.assign(rows, 0);
  wk.bx.assign(rows, 0);
  wk.bz.assign(rows, 0);
  wk.by.assign(rows, 0);
  wk.layer_first.assign(std::size_t(ny) + 1, 0);
  for (int w = 0; w < W; ++w) {
    wk.edge_range.push_back(range_word(w, a, nx - 2 - a));
    wk.sample_range.push_back(range_word(w, a, nx - 1 - a));
  }
  wk.cell_range = wk.edge_range;

  auto layers = [&](int j0, int j1, auto&& fn) {
    tbb::parallel_for(tbb::blocked_range<int>(j0, j1, 1), [&](const tbb::blocked_range<int>& r) {
      for (int j = r.begin(); j < r.end(); ++j) fn(j);
    });
  };

  // 1. Sign bits of the meshed samples.
  layers(jlo, jhi + 1, [&](int j) {
    for (int k = klo; k <= khi; ++k) {
      const float* p = &b.d[(std::size_t(j) * nz + k) * nx];
      u64* s = &wk.sign[wk.row(j, k)];
      for (int w = 0; w * 64 < nx; ++w) {
        const int n = std::min(64, nx - w * 64);
        u64 m = 0;
        for (int i = 0; i < n; ++i) m |= u64(p[w * 64 + i] > 0.0f) << i;
        s[w] = m & wk.sample_range[w];
      }
    }
  });

  // 2. Crossed edges and per-word vertex bases, per sample layer; each layer's vertex count.
  std::vector<std::uint32_t> layer_count(static_cast<std::size_t>(ny), 0);
  layers(jlo, jhi + 1, [&](int j) {
    std::uint32_t count = 0;
    for (int k = klo; k <= khi; ++k) {
      const std::size_t r = wk.row(j, k);
      const u64* s = &wk.sign[r];
      for (int w = 0; w + 1 < W; ++w) {
        wk.xc[r + w] = (s[w] ^ ((s[w] >> 1) | (s[w + 1] << 63))) & wk.edge_range[w];
        wk.zc[r + w] = k < khi ? (s[w] ^ wk.sign[wk.row(j, k + 1) + w]) & wk.sample_range[w] : 0;
        wk.yc[r + w] = j < jhi ? (s[w] ^ wk.sign[wk.row(j + 1, k) + w]) & wk.sample_range[w] : 0;
      }
      for (int w = 0; w + 1 < W; ++w) wk.bx[r + w] = count, count += std::uint32_t(std::popcount(wk.xc[r + w]));
      for (int w = 0; w + 1 < W; ++w) wk.bz[r + w] = count, count += std::uint32_t(std::popcount(wk.zc[r + w]));
      for (int w = 0; w + 1 < W; ++w) wk.by[r + w] = count, count += std::uint32_t(std::popcount(wk.yc[r + w]));
    }
    layer_count[j] = count;
  });
  std::uint64_t total = 0;
  for (int j = 0; j < ny; ++j) {
    wk.layer_first[j] = std::uint32_t(total);
    total += layer_count[j];
  }

  // 3. Vertices.
  VolumeMesh mesh;
  mesh.positions.resize(total * 3);
  mesh.normals.resize(total * 3);
  std::atomic<bool> non_finite{false};
  const double cell = b.cell_m;
  auto gradient = [&](int i, int j, int k, double g[3]) {
    g[0] = double(b.at(i + 1, j, k)) - double(b.at(i - 1, j, k));
    g[1] = double(b.at(i, j + 1, k)) - double(b.at(i, j - 1, k));
    g[2] = double(b.at(i, j, k + 1)) - double(b.at(i, j, k - 1));
  };
  layers(jlo, jhi + 1, [&](int j) {
    std::uint32_t v = wk.layer_first[j];
    bool bad = false;
    auto emit = [&](int axis, int i, int k) {
      const int di = axis == 0, dj = axis == 1, dk = axis == 2;
      const double d0 = b.at(i, j, k), d1 = b.at(i + di, j + dj, k + dk);
      const double t = d0 / (d0 - d1);
      double g0[3], g1[3];
      gradient(i, j, k, g0);
      gradient(i + di, j + dj, k + dk, g1);
      double n[3], len2 = 0;
      for (int c = 0; c < 3; ++c) {
        n[c] = -((1.0 - t) * g0[c] + t * g1[c]);
        len2 += n[c] * n[c];
      }
      const double len = std::sqrt(len2);
      if (len > 0 && std::isfinite(len)) {
        for (double& c : n) c /= len;
      } else {
        n[0] = n[1] = n[2] = 0;
        n[axis] = d0 > 0 ? 1.0 : -1.0;  // from the solid end towards the air end
      }
      double p[3] = {double(b.ix0 + i), double(b.iy0 + j), double(b.iz0 + k)};
      p[axis] += t;
      float* P = &mesh.positions[std::size_t(v) * 3];
      float* N = &mesh.normals[std::size_t(v) * 3];
      for (int c = 0; c < 3; ++c) {
        P[c] = float(p[c] * cell);
        N[c] = float(n[c]);
      }
      bad |= !std::isfinite(t) || !std::isfinite(len2);
      ++v;
    };
    auto each_bit = [&](const u64* m, int axis, int k) {
      for (int w = 0; w + 1 < W; ++w)
        for (u64 bits = m[w]; bits; bits &= bits - 1) emit(axis, w * 64 + std::countr_zero(bits), k);
    };
    for (int k = klo; k <= khi; ++k) {
      const std::size_t r = wk.row(j, k);
      each_bit(&wk.xc[r], 0, k);
      each_bit(&wk.zc[r], 2, k);
      each_bit(&wk.yc[r], 1, k);
    }
    if (bad) non_finite = true;
  });
  if (non_finite)
    throw Error("d", "expected finite densities at every crossed edge's samples and their neighbours, got a "
                     "non-finite value (NaN or infinity)");

  // 4. Triangles, per cell layer, concatenated in layer order.
  std::vector<std::vector<std::uint32_t>> tris(static_cast<std::size_t>(ny));
  const mc::CaseTable& table = mc::kCases;
  layers(jlo, jhi, [&](int j) {
    std::vector<std::uint32_t>& out = tris[j];
    const std::uint32_t f0 = wk.layer_first[j], f1 = wk.layer_first[j + 1];
    for (int k = klo; k < khi; ++k) {
      const std::size_t r00 = wk.row(j, k), r10 = wk.row(j + 1, k), r01 = wk.row(j, k + 1), r11 = wk.row(j + 1, k + 1);
      const u64 *s00 = &wk.sign[r00], *s10 = &wk.sign[r10], *s01 = &wk.sign[r01], *s11 = &wk.sign[r11];
      for (int w = 0; w + 1 < W; ++w) {
        const u64 any = s00[w] | s10[w] | s01[w] | s11[w];
        const u64 any_next = s00[w + 1] | s10[w + 1] | s01[w + 1] | s11[w + 1];
        const u64 all = s00[w] & s10[w] & s01[w] & s11[w];
        const u64 all_next = s00[w + 1] & s10[w + 1] & s01[w + 1] & s11[w + 1];
        const u64 some = any | (any >> 1) | (any_next << 63);
        const u64 every = all & ((all >> 1) | (all_next << 63));
        for (u64 active = some & ~every & wk.cell_range[w]; active; active &= active - 1) {
          const int i = w * 64 + std::countr_zero(active);
          const unsigned cfg = two_bits(s00, i) | two_bits(s10, i) << 2 | two_bits(s01, i) << 4 | two_bits(s11, i) << 6;
          std::uint32_t vert[12];
          for (unsigned m = table.edge_mask[cfg]; m; m &= m - 1) {
            const int e = std::countr_zero(m), o = e & 3, lo = o & 1, hi = o >> 1;
            std::uint32_t id;
            switch (e >> 2) {
              case 0: {  // x edge at (dy, dz) = (lo, hi)
                const std::size_t rr = wk.row(j + lo, k + hi) + (i >> 6);
                id = (lo ? f1 : f0) + wk.bx[rr] + std::uint32_t(rank_below(wk.xc[rr], i & 63));
                break;
              }
              case 1: {  // y edge at (dx, dz) = (lo, hi)
                const int ii = i + lo;
                const std::size_t rr = wk.row(j, k + hi) + (ii >> 6);
                id = f0 + wk.by[rr] + std::uint32_t(rank_below(wk.yc[rr], ii & 63));
                break;
              }
              default: {  // z edge at (dx, dy) = (lo, hi)
                const int ii = i + lo;
                const std::size_t rr = wk.row(j + hi, k) + (ii >> 6);
                id = (hi ? f1 : f0) + wk.bz[rr] + std::uint32_t(rank_below(wk.zc[rr], ii & 63));
                break;
              }
            }
            vert[e] = id;
          }
          const std::uint8_t* te = table.edges[cfg];
          for (int t = 0; t < 3 * table.count[cfg]; ++t) out.push_back(vert[te[t]]);
        }
      }
    }
  });
  std::size_t n_idx = 0;
  for (auto& t : tris) n_idx += t.size();
  mesh.indices.reserve(n_idx);
  for (auto& t : tris) mesh.indices.insert(mesh.indices.end(), t.begin(), t.end());
  return mesh;
}

}  // namespace relief
