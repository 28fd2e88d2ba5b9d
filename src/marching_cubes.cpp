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
// Steps 1-4 run over sample layers in parallel on the current oneTBB arena; each layer's output has a
// fixed place (vertex offsets from a prefix sum, triangle lists concatenated in layer order), so the
// bytes are the same for any thread count.
//
// The per-layer kernels are compiled for each Highway target (Google Highway's foreach_target and
// HWY_DYNAMIC_DISPATCH): the sign bits use SIMD comparisons (StoreMaskBits), and the rank popcounts
// become one instruction on targets that have it. Every target computes the same bits: the sign test is
// exact, the rest is the same scalar code (integer operations, and double arithmetic without FMA
// contraction: hwy_kernels.hpp turns contraction off).

// The shared part below is compiled once; foreach_target re-includes this file per target.
#ifndef RELIEF_MARCHING_CUBES_SHARED
#define RELIEF_MARCHING_CUBES_SHARED
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

#include "marching_cubes_tables.hpp"
#include "relief/error.hpp"
#include "relief/volume_mesh.hpp"

namespace relief::mc_kernel {

using u64 = std::uint64_t;

// Bits [lo, hi] (inclusive, 0 ≤ lo ≤ hi) set in word w of a row mask.
inline u64 range_word(int w, int lo, int hi) {
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

struct Work {
  const DensityBlock* b = nullptr;
  int a = 1;                         // apron
  int W = 0;                         // words per row, the last one a zero pad
  int jlo = 0, jhi = 0, klo = 0, khi = 0;  // meshed sample range (inclusive)
  // Per (sample layer, row): sign bits, crossed x / z / y edges and their per-word vertex bases (local to
  // the layer). Index: (j * nz + k) * W + w.
  std::vector<u64> sign, xc, zc, yc;
  std::vector<std::uint32_t> bx, bz, by;
  std::vector<std::uint32_t> layer_count, layer_first;  // per sample layer j: vertices, index of the first
  std::vector<u64> edge_range, sample_range;  // per word: bits [a, nx − 2 − a] (edges, cells), [a, nx − 1 − a]
  float* positions = nullptr;
  float* normals = nullptr;

  std::size_t row(int j, int k) const { return (std::size_t(j) * b->nz + k) * W; }
};

}  // namespace relief::mc_kernel
#endif  // RELIEF_MARCHING_CUBES_SHARED

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "marching_cubes.cpp"
#include "hwy_kernels.hpp"  // the target list, foreach_target.h, highway.h, no FP contraction

HWY_BEFORE_NAMESPACE();
namespace relief::mc_kernel {
namespace HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;

inline int rank_below(u64 word, int r) { return std::popcount(word & ((u64(1) << r) - 1)); }

// 1. Sign bits (density > 0) of layer j's meshed rows.
void SignLayer(Work& wk, int j) {
  const DensityBlock& b = *wk.b;
  const int nx = b.nx;
  const hn::ScalableTag<float> d;
  const int N = int(hn::Lanes(d));
  const auto zero = hn::Zero(d);
  for (int k = wk.klo; k <= wk.khi; ++k) {
    const float* HWY_RESTRICT p = &b.d[(std::size_t(j) * b.nz + k) * nx];
    u64* s = &wk.sign[wk.row(j, k)];
    for (int w = 0; w * 64 < nx; ++w) {
      const int n = std::min(64, nx - w * 64);
      const float* q = p + w * 64;
      u64 m = 0;
      if (n == 64 && N <= 64 && 64 % N == 0) {
        for (int i = 0; i < 64; i += N) {
          u64 bits = 0;
          hn::StoreMaskBits(d, hn::Gt(hn::LoadU(d, q + i), zero), reinterpret_cast<std::uint8_t*>(&bits));
          if (N < 64) bits &= (u64(1) << N) - 1;
          m |= bits << i;
        }
      } else {
        for (int i = 0; i < n; ++i) m |= u64(q[i] > 0.0f) << i;
      }
      s[w] = m & wk.sample_range[w];
    }
  }
}

// 2. Crossed edges of layer j's meshed rows and their per-word vertex bases; returns the layer's count.
std::uint32_t CountLayer(Work& wk, int j) {
  const int W = wk.W;
  std::uint32_t count = 0;
  for (int k = wk.klo; k <= wk.khi; ++k) {
    const std::size_t r = wk.row(j, k);
    const u64* s = &wk.sign[r];
    const u64* sz = k < wk.khi ? &wk.sign[wk.row(j, k + 1)] : s;
    const u64* sy = j < wk.jhi ? &wk.sign[wk.row(j + 1, k)] : s;
    for (int w = 0; w + 1 < W; ++w) {
      wk.xc[r + w] = (s[w] ^ ((s[w] >> 1) | (s[w + 1] << 63))) & wk.edge_range[w];
      wk.zc[r + w] = (s[w] ^ sz[w]) & wk.sample_range[w];
      wk.yc[r + w] = (s[w] ^ sy[w]) & wk.sample_range[w];
    }
    for (int w = 0; w + 1 < W; ++w) wk.bx[r + w] = count, count += std::uint32_t(std::popcount(wk.xc[r + w]));
    for (int w = 0; w + 1 < W; ++w) wk.bz[r + w] = count, count += std::uint32_t(std::popcount(wk.zc[r + w]));
    for (int w = 0; w + 1 < W; ++w) wk.by[r + w] = count, count += std::uint32_t(std::popcount(wk.yc[r + w]));
  }
  return count;
}

// 3. The vertices of layer j's crossed edges, at their final place; false when one is not finite.
bool VertexLayer(const Work& wk, int j) {
  const DensityBlock& b = *wk.b;
  const int W = wk.W;
  const double cell = b.cell_m;
  std::uint32_t v = wk.layer_first[j];
  bool ok = true;
  auto gradient = [&](int i, int jj, int k, double g[3]) {
    g[0] = double(b.at(i + 1, jj, k)) - double(b.at(i - 1, jj, k));
    g[1] = double(b.at(i, jj + 1, k)) - double(b.at(i, jj - 1, k));
    g[2] = double(b.at(i, jj, k + 1)) - double(b.at(i, jj, k - 1));
  };
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
    float* P = wk.positions + std::size_t(v) * 3;
    float* Nrm = wk.normals + std::size_t(v) * 3;
    for (int c = 0; c < 3; ++c) {
      P[c] = float(p[c] * cell);
      Nrm[c] = float(n[c]);
    }
    ok &= std::isfinite(t) && std::isfinite(len2);
    ++v;
  };
  auto each_bit = [&](const u64* m, int axis, int k) {
    for (int w = 0; w + 1 < W; ++w)
      for (u64 bits = m[w]; bits; bits &= bits - 1) emit(axis, w * 64 + std::countr_zero(bits), k);
  };
  for (int k = wk.klo; k <= wk.khi; ++k) {
    const std::size_t r = wk.row(j, k);
    each_bit(&wk.xc[r], 0, k);
    each_bit(&wk.zc[r], 2, k);
    each_bit(&wk.yc[r], 1, k);
  }
  return ok;
}

// 4. The triangles of cell layer j (between sample layers j and j + 1) into out, a buffer whose size is
// the caller's guess (grown as needed); out ends with exactly the layer's indices.
void TriangleLayer(const Work& wk, int j, std::vector<std::uint32_t>& out) {
  const int W = wk.W;
  const mc::CaseTable& table = mc::kCases;
  const std::uint32_t first[2] = {wk.layer_first[j], wk.layer_first[j + 1]};
  std::size_t at = 0;
  for (int k = wk.klo; k < wk.khi; ++k) {
    // Rows (j + dy, k + dz) as r[dy][dz].
    const std::size_t r[2][2] = {{wk.row(j, k), wk.row(j, k + 1)}, {wk.row(j + 1, k), wk.row(j + 1, k + 1)}};
    const u64 *s00 = &wk.sign[r[0][0]], *s10 = &wk.sign[r[1][0]], *s01 = &wk.sign[r[0][1]], *s11 = &wk.sign[r[1][1]];
    for (int w = 0; w + 1 < W; ++w) {
      const u64 any = s00[w] | s10[w] | s01[w] | s11[w];
      const u64 any_next = s00[w + 1] | s10[w + 1] | s01[w + 1] | s11[w + 1];
      const u64 all = s00[w] & s10[w] & s01[w] & s11[w];
      const u64 all_next = s00[w + 1] & s10[w + 1] & s01[w + 1] & s11[w + 1];
      const u64 some = any | (any >> 1) | (any_next << 63);
      const u64 every = all & ((all >> 1) | (all_next << 63));
      for (u64 active = some & ~every & wk.edge_range[w]; active; active &= active - 1) {
        const int i = w * 64 + std::countr_zero(active);
        const unsigned cfg = two_bits(s00, i) | two_bits(s10, i) << 2 | two_bits(s01, i) << 4 | two_bits(s11, i) << 6;
        std::uint32_t vert[12];
        for (unsigned m = table.edge_mask[cfg]; m; m &= m - 1) {
          const int e = std::countr_zero(m), o = e & 3, lo = o & 1, hi = o >> 1;
          std::uint32_t id;
          switch (e >> 2) {
            case 0: {  // x edge at (dy, dz) = (lo, hi)
              const std::size_t rr = r[lo][hi] + (i >> 6);
              id = first[lo] + wk.bx[rr] + std::uint32_t(rank_below(wk.xc[rr], i & 63));
              break;
            }
            case 1: {  // y edge at (dx, dz) = (lo, hi)
              const int ii = i + lo;
              const std::size_t rr = r[0][hi] + (ii >> 6);
              id = first[0] + wk.by[rr] + std::uint32_t(rank_below(wk.yc[rr], ii & 63));
              break;
            }
            default: {  // z edge at (dx, dy) = (lo, hi)
              const int ii = i + lo;
              const std::size_t rr = r[hi][0] + (ii >> 6);
              id = first[hi] + wk.bz[rr] + std::uint32_t(rank_below(wk.zc[rr], ii & 63));
              break;
            }
          }
          vert[e] = id;
        }
        const std::uint8_t* te = table.edges[cfg];
        const int n = 3 * table.count[cfg];
        if (at + 3 * mc::kMaxTriangles > out.size()) out.resize(std::max(2 * out.size(), at + 3 * mc::kMaxTriangles));
        std::uint32_t* o = out.data() + at;
        for (int t = 0; t < n; ++t) o[t] = vert[te[t]];
        at += std::size_t(n);
      }
    }
  }
  out.resize(at);
}

}  // namespace HWY_NAMESPACE
}  // namespace relief::mc_kernel
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace relief {

namespace mc_kernel {
HWY_EXPORT(SignLayer);
HWY_EXPORT(CountLayer);
HWY_EXPORT(VertexLayer);
HWY_EXPORT(TriangleLayer);
}  // namespace mc_kernel

namespace {

[[noreturn]] void too_small(const char* field, int n, int apron) {
  throw Error(field, "expected at least 2·apron + 2 = " + std::to_string(2 * apron + 2) +
                         " samples (one meshed cell inside the apron of " + std::to_string(apron) + "), got " +
                         std::to_string(n));
}

template <class F>
void each_layer(int j0, int j1, F&& fn) {
  tbb::parallel_for(tbb::blocked_range<int>(j0, j1, 1), [&](const tbb::blocked_range<int>& r) {
    for (int j = r.begin(); j < r.end(); ++j) fn(j);
  });
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

  using namespace mc_kernel;
  const int nx = b.nx, ny = b.ny, nz = b.nz, a = apron;
  Work wk;
  wk.b = &b;
  wk.a = a;
  wk.W = (nx + 63) / 64 + 1;
  wk.jlo = a, wk.jhi = ny - 1 - a, wk.klo = a, wk.khi = nz - 1 - a;
  const std::size_t rows = std::size_t(ny) * nz * wk.W;
  for (auto* v : {&wk.sign, &wk.xc, &wk.zc, &wk.yc}) v->assign(rows, 0);
  for (auto* v : {&wk.bx, &wk.bz, &wk.by}) v->assign(rows, 0);
  wk.layer_count.assign(std::size_t(ny) + 1, 0);
  wk.layer_first.assign(std::size_t(ny) + 1, 0);
  for (int w = 0; w < wk.W; ++w) {
    wk.edge_range.push_back(range_word(w, a, nx - 2 - a));
    wk.sample_range.push_back(range_word(w, a, nx - 1 - a));
  }

  each_layer(wk.jlo, wk.jhi + 1, [&](int j) { HWY_DYNAMIC_DISPATCH(SignLayer)(wk, j); });
  each_layer(wk.jlo, wk.jhi + 1, [&](int j) { wk.layer_count[j] = HWY_DYNAMIC_DISPATCH(CountLayer)(wk, j); });
  std::uint64_t total = 0;
  for (int j = 0; j <= ny; ++j) {
    wk.layer_first[j] = std::uint32_t(total);
    total += wk.layer_count[j];
  }

  VolumeMesh mesh;
  mesh.positions.resize(total * 3);
  mesh.normals.resize(total * 3);
  wk.positions = mesh.positions.data();
  wk.normals = mesh.normals.data();
  std::atomic<bool> non_finite{false};
  each_layer(wk.jlo, wk.jhi + 1, [&](int j) {
    if (!HWY_DYNAMIC_DISPATCH(VertexLayer)(wk, j)) non_finite = true;
  });
  if (non_finite)
    throw Error("d", "expected finite densities at every crossed edge's samples and their neighbours, got a "
                     "non-finite value (NaN or infinity)");

  // Triangles per cell layer, concatenated in layer order. A closed surface has about two triangles per
  // vertex: each layer's list starts with room for that.
  std::vector<std::vector<std::uint32_t>> tris(static_cast<std::size_t>(ny));
  each_layer(wk.jlo, wk.jhi, [&](int j) {
    tris[j].resize(6 * std::size_t(wk.layer_count[j]) + 96);
    HWY_DYNAMIC_DISPATCH(TriangleLayer)(wk, j, tris[j]);
  });
  std::size_t n_idx = 0;
  for (auto& t : tris) n_idx += t.size();
  mesh.indices.resize(n_idx);
  std::vector<std::size_t> at(tris.size() + 1, 0);
  for (std::size_t j = 0; j < tris.size(); ++j) at[j + 1] = at[j] + tris[j].size();
  each_layer(0, ny, [&](int j) {
    if (!tris[j].empty()) std::memcpy(mesh.indices.data() + at[j], tris[j].data(), tris[j].size() * 4);
  });
  return mesh;
}

}  // namespace relief
#endif  // HWY_ONCE
