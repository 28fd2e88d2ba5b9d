// Droplet hydraulic erosion.
//
// Sources:
//   * H. T. Beyer, "Implementation of a method for hydraulic erosion", Bachelor's thesis, TU
//     München, 2015 — the droplet model: inertia-blended direction, sediment capacity from slope,
//     speed and water, erosion with a radius brush, deposition, evaporation.
//   * S. Lague, "Hydraulic Erosion" (2019, github.com/SebLague/Hydraulic-Erosion) — the parameter
//     set (inertia, capacity, minimum capacity, erode, deposit, evaporate, gravity, lifetime, brush
//     radius) and the (r − d) brush weights. Two departures, both deliberate: speed grows when the
//     droplet descends (v² − Δy·g; Lague's v² + Δy·g slows droplets going downhill), and erosion is
//     bounded by elevation 0 instead of by "positive height", which creates spikes below sea level.
//     As in both sources, a droplet erodes with the brush and deposits on the four cells of its
//     bilinear cell (uphill and over capacity); only a droplet that dies on land spreads what it
//     still carries with the brush.
//   * Google Highway (github.com/google/highway): foreach_target multi-target compilation and
//     HWY_DYNAMIC_DISPATCH, once per batch of tiles.
//
// World units: positions and the brush are in metres, heights in metres, sediment in m³, so a
// droplet moves, erodes and deposits the same volume at any sample spacing.
//
// Speed. A droplet step is one long chain of dependent operations (position → bilinear heights →
// gradient → direction → square root and division → next position; and heights → capacity →
// brush → the heights the next step reads), so one droplet at a time leaves the core mostly idle.
// Each thread therefore runs one droplet per vector lane (8 on AVX2/AVX-512), each from a
// different tile of the same phase: those tiles touch disjoint cells, so running them side by
// side changes nothing in the result. The step up to the capacity runs on vectors (the bilinear
// corners are gathers); the brush or the bilinear deposit then runs lane by lane. The droplet
// state is single precision (the layer's precision; sediment and mass totals stay in double).
// The brush is a box of rows of ≤ 8 cells processed as masked vectors of at most 8 floats.
//
// Exactness across Highway targets. The per-droplet arithmetic is float in a fixed order (the
// build uses -ffp-contract=off): the same IEEE operations lane-wise on vectors as one at a time.
// Brush cells are independent lane-wise operations, and the material moved is summed per box
// column over the rows in order, then over the columns in a fixed tree (blocks of 8), whatever
// the vector width: every target (8, 4 or 1 droplets in flight), and the one-lane brush used near
// the right border, gives bit-identical heights and totals (tests/test_erosion.cpp forces each
// compiled target).

// The shared part below is compiled once; foreach_target re-includes this file per target.
#ifndef RELIEF_EROSION_HYDRAULIC_SHARED
#define RELIEF_EROSION_HYDRAULIC_SHARED
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include "relief/erosion.hpp"
#include "relief/error.hpp"
#include "relief/random.hpp"

namespace relief::erosion {
namespace kernel {

// Everything a batch of droplets needs, in the units of the step (cells, normalised heights).
struct Kernel {
  float* e = nullptr;
  int nx = 0, nz = 0;
  int lifetime = 0;
  float inertia = 0, keep_dir = 0;         // inertia, 1 − inertia
  float capacity = 0, min_capacity = 0;    // s/m, metres of mean brush height
  float erode = 0, deposit = 0, evap_keep = 0, gravity = 0;
  float gs = 0;      // height_m / cell_m: normalised difference per cell → metres per metre
  float H = 0;       // height_m
  float cell2 = 0;   // cell_m²
  float area = 0;    // π·brush_radius_m²
  float step_c = 0;  // step in cells
  float sea = 0;
  float xlim = 0, zlim = 0;  // nx − 1, nz − 1
  double m3 = 0;     // m³ per unit of normalised height on one cell: height_m · cell_m²
  // The brush as a box of rows −R..R, columns −R..R: weights (normalised height per m³) in rows of
  // stride P (P = w rounded up to 8), zero outside the disk and in the padding.
  int R = 0, w = 0, P = 0;
  const float* box = nullptr;
  // The brush as a cell list with double weights (Σ = 1), for brushes cut by the window's border.
  const int* cell_di = nullptr;
  const int* cell_dj = nullptr;
  const double* cell_w = nullptr;
  int ncells = 0;
  double to_norm = 0;  // 1 / (height_m · cell_m²)
};

// One block's droplets of one round: start positions (x, z interleaved) in the block's own cell
// coordinates, whose origin is window cell (ox, oz) (the block's world origin minus the droplets'
// reach, so that positions stay positive); run in order, totals into *st. A droplet's arithmetic in
// block coordinates is the same in every window that holds it (translation-exact floats).
struct TileJob {
  const float* pos = nullptr;
  std::uint32_t n = 0;
  HydraulicStats* st = nullptr;
  std::int32_t ox = 0, oz = 0;
};

}  // namespace kernel
}  // namespace relief::erosion
#endif  // RELIEF_EROSION_HYDRAULIC_SHARED

// ---- the per-target droplet kernels ------------------------------------------------------------
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "erosion_hydraulic.cpp"
#include "hwy_kernels.hpp"  // the target list, foreach_target.h, highway.h, no FP contraction
#include <hwy/aligned_allocator.h>

HWY_BEFORE_NAMESPACE();
namespace relief::erosion::kernel {
namespace HWY_NAMESPACE {
namespace {

namespace hn = hwy::HWY_NAMESPACE;

// Applies clamp(old + vs·weight, lo, hi) over the brush box whose top-left cell is `base` and
// returns Σ (new − old) (normalised), summed per column over the rows in order, then over the
// columns in blocks of 8 as ((a0+a1)+(a2+a3))+((a4+a5)+(a6+a7)), the blocks in order. Lanes of
// weight 0 are neither read nor written. `acc` holds P floats, 32-byte aligned. Any lane count
// gives the same bits.
template <class D>
HWY_INLINE float BrushBox(D d, const Kernel& k, float* HWY_RESTRICT base, float vs, float lo, float hi,
                          float* HWY_RESTRICT acc) {
  const int N = int(hn::Lanes(d)), w = k.w, P = k.P;
  const std::ptrdiff_t nx = k.nx;
  const float* HWY_RESTRICT box = k.box;
  const auto zero = hn::Zero(d), vv = hn::Set(d, vs), vlo = hn::Set(d, lo), vhi = hn::Set(d, hi);
  auto cell = [&](float* HWY_RESTRICT q, const float* HWY_RESTRICT wq) {
    const auto wv = hn::Load(d, wq);
    const auto m = hn::Gt(wv, zero);
    // 0 outside the disk: nothing moves there. AVX2 and AVX-512 load only the disk's lanes; the
    // 128-bit targets read up to 3 cells past the box, never past the row (see Brush) and never
    // into cells that another tile of the phase writes (those lie ≥ 4 cells further: tiles are
    // 2·reach wide and reach has 2 cells of margin on each side).
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX2
    const auto old = hn::MaskedLoad(m, d, q);
#else
    const auto old = hn::IfThenElseZero(m, hn::LoadU(d, q));
#endif
    const auto now = hn::Min(hn::Max(hn::Add(old, hn::Mul(vv, wv)), vlo), vhi);
    hn::BlendedStore(now, m, d, q);
    return hn::Sub(now, old);
  };
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX2  // 256-bit vectors or wider: CappedTag<float, 8> is 8 lanes
  if constexpr (hn::MaxLanes(D()) == 8) {
    if (HWY_LIKELY(P == 8)) {  // one vector per row, the column sums in a register
      auto a = zero;
      for (int r = 0; r < w; ++r) a = hn::Add(a, cell(base + r * nx, box + r * 8));
      a = hn::Add(a, hn::Shuffle2301(a));         // lane 0: a0+a1, lane 2: a2+a3, …
      a = hn::Add(a, hn::Shuffle1032(a));         // lane 0: (a0+a1)+(a2+a3), lane 4: (a4+a5)+(a6+a7)
      a = hn::Add(a, hn::SwapAdjacentBlocks(a));  // lane 0: the block's sum
      return hn::GetLane(a);
    }
  }
#endif
  for (int b = 0; b < P; b += N) hn::Store(zero, d, acc + b);
  for (int r = 0; r < w; ++r) {
    float* HWY_RESTRICT row = base + r * nx;
    const float* HWY_RESTRICT wr = box + std::ptrdiff_t(r) * P;
    for (int b = 0; b < w; b += N) hn::Store(hn::Add(hn::Load(d, acc + b), cell(row + b, wr + b)), d, acc + b);
  }
  float total = 0;
  for (int b = 0; b < w; b += 8) {
    const float* a = acc + b;
    const float s = ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
    total = b == 0 ? s : total + s;
  }
  return total;
}

// The droplets in flight: one per vector lane (8 on AVX2 and AVX-512, 4 on the 128-bit targets, 1 on
// the scalar fallback), each from its own tile. The step up to the heights and the capacity runs
// lane-wise on vectors (the 8 bilinear corners are gathers); what a step does to the heights
// (brush, bilinear deposit) and the double-precision sediment run per lane, in lane order.
class Batch {
 public:
  using DF = hn::CappedTag<float, 8>;
  using DI = hn::RebindToSigned<DF>;
  static constexpr int kMax = 8;

  Batch(const Kernel& k, const TileJob* jobs, std::size_t njobs, std::atomic<std::size_t>* next)
      : k_(k), jobs_(jobs), njobs_(njobs), next_(next) {
    acc_ = hwy::AllocateAligned<float>(std::size_t(kMax) * (k.P + 16));
    for (std::size_t i = 0; i < std::size_t(kMax) * (k.P + 16); ++i) acc_[i] = 0;
  }

  void Run() {
    const DF df;
    const DI di;
    const int N = int(hn::Lanes(df));
    int active = 0;
    for (int l = 0; l < N; ++l) {
      lanes_[l].acc = acc_.get() + std::size_t(l) * (k_.P + 16);
      lanes_[l].active = Next(l);
      if (!lanes_[l].active) Park(l);
      active += lanes_[l].active;
    }
    const auto zero = hn::Zero(df), one = hn::Set(df, 1.0f);
    const auto vnx = hn::Set(di, k_.nx);
    const auto xlim0 = hn::Set(df, k_.xlim), zlim0 = hn::Set(df, k_.zlim);
    const float* HWY_RESTRICT e = k_.e;
    const std::ptrdiff_t nx = k_.nx;
    // Bilinear corners of (px, pz), as the scalar Height() and Step() compute them.
    struct Corners {
      hn::Vec<DI> ix, iz;
      hn::Vec<DF> fx, fz, a, b, c, d;
    };
    // Positions are in each lane's block coordinates; the cell indices add the block's origin.
    auto corners = [&](hn::Vec<DF> px, hn::Vec<DF> pz) {
      Corners r;
      const auto tx = hn::ConvertTo(di, px), tz = hn::ConvertTo(di, pz);
      r.fx = hn::Sub(px, hn::ConvertTo(df, tx));
      r.fz = hn::Sub(pz, hn::ConvertTo(df, tz));
      r.ix = hn::Add(tx, hn::Load(di, ox_));
      r.iz = hn::Add(tz, hn::Load(di, oz_));
      const auto idx = hn::Add(hn::Mul(r.iz, vnx), r.ix);
      r.a = hn::GatherIndex(df, e, idx);
      r.b = hn::GatherIndex(df, e + 1, idx);
      r.c = hn::GatherIndex(df, e + nx, idx);
      r.d = hn::GatherIndex(df, e + nx + 1, idx);
      return r;
    };
    auto height = [&](const Corners& q) {
      const auto ofx = hn::Sub(one, q.fx), ofz = hn::Sub(one, q.fz);
      return hn::Add(hn::Add(hn::Add(hn::Mul(hn::Mul(q.a, ofx), ofz), hn::Mul(hn::Mul(q.b, q.fx), ofz)),
                             hn::Mul(hn::Mul(q.c, ofx), q.fz)),
                     hn::Mul(hn::Mul(q.d, q.fx), q.fz));
    };
    const auto gs = hn::Set(df, k_.gs), inertia = hn::Set(df, k_.inertia), keep = hn::Set(df, k_.keep_dir);
    const auto tiny = hn::Set(df, 1e-12f), stepc = hn::Set(df, k_.step_c);
    const auto H = hn::Set(df, k_.H);
    const auto capacity = hn::Set(df, k_.capacity), minc = hn::Set(df, k_.min_capacity);
    const auto area = hn::Set(df, k_.area), gravity = hn::Set(df, k_.gravity), evap = hn::Set(df, k_.evap_keep);
    HWY_ALIGN std::int32_t ix[kMax], iz[kMax];
    HWY_ALIGN float fx[kMax], fz[kMax], dy[kMax], cap[kMax], hnew[kMax];
    HWY_ALIGN std::uint8_t alive_bits[8], go_bits[8];
    while (active > 0) {
      const auto px = hn::Load(df, px_), pz = hn::Load(df, pz_);
      const Corners q = corners(px, pz);
      const auto gx = hn::Mul(hn::Add(hn::Mul(hn::Sub(q.b, q.a), hn::Sub(one, q.fz)), hn::Mul(hn::Sub(q.d, q.c), q.fz)), gs);
      const auto gz = hn::Mul(hn::Add(hn::Mul(hn::Sub(q.c, q.a), hn::Sub(one, q.fx)), hn::Mul(hn::Sub(q.d, q.b), q.fx)), gs);
      const auto h_old = height(q);
      auto dx = hn::Sub(hn::Mul(hn::Load(df, dx_), inertia), hn::Mul(gx, keep));
      auto dz = hn::Sub(hn::Mul(hn::Load(df, dz_), inertia), hn::Mul(gz, keep));
      const auto len = hn::Sqrt(hn::Add(hn::Mul(dx, dx), hn::Mul(dz, dz)));
      const auto alive = hn::Ge(len, tiny);  // false also for NaN: no slope, no momentum
      dx = hn::Div(dx, len);
      dz = hn::Div(dz, len);
      const auto npx = hn::Add(px, hn::Mul(dx, stepc)), npz = hn::Add(pz, hn::Mul(dz, stepc));
      // Inside the window: 0 ≤ np + o < lim, i.e. −o ≤ np < lim − o (integers, exact in float).
      const auto negox = hn::ConvertTo(df, hn::Neg(hn::Load(di, ox_)));
      const auto negoz = hn::ConvertTo(df, hn::Neg(hn::Load(di, oz_)));
      const auto inside = hn::And(hn::And(hn::Ge(npx, negox), hn::Ge(npz, negoz)),
                                  hn::And(hn::Lt(npx, hn::Add(xlim0, negox)), hn::Lt(npz, hn::Add(zlim0, negoz))));
      const auto go = hn::And(alive, inside);
      // Lanes that stop here read the heights at window cell (0, 0): always inside the grid.
      const auto h_new = height(corners(hn::IfThenElse(go, npx, negox), hn::IfThenElse(go, npz, negoz)));
      const auto vdy = hn::Mul(hn::Sub(h_new, h_old), H);  // metres, negative downhill
      const auto speed = hn::Load(df, speed_), water = hn::Load(df, water_);
      const auto c0 = hn::Mul(hn::Mul(hn::Mul(hn::Neg(vdy), speed), water), capacity);
      // std::max(c0, minc) is (c0 < minc ? minc : c0); std::max(0, v) is (0 < v ? v : 0).
      const auto vcap = hn::Mul(hn::IfThenElse(hn::Lt(c0, minc), minc, c0), area);
      const auto v = hn::Sub(hn::Mul(speed, speed), hn::Mul(vdy, gravity));
      hn::Store(hn::IfThenElse(go, npx, px), df, px_);
      hn::Store(hn::IfThenElse(go, npz, pz), df, pz_);
      hn::Store(dx, df, dx_);
      hn::Store(dz, df, dz_);
      hn::Store(hn::Sqrt(hn::IfThenElseZero(hn::Lt(zero, v), v)), df, speed_);
      hn::Store(hn::Mul(water, evap), df, water_);
      hn::Store(q.ix, di, ix);
      hn::Store(q.iz, di, iz);
      hn::Store(q.fx, df, fx);
      hn::Store(q.fz, df, fz);
      hn::Store(vdy, df, dy);
      hn::Store(vcap, df, cap);
      hn::Store(h_new, df, hnew);
      hn::StoreMaskBits(df, alive, alive_bits);
      hn::StoreMaskBits(df, go, go_bits);
      for (int l = 0; l < N; ++l) {
        Lane& L = lanes_[l];
        if (!L.active) continue;
        bool more;
        if (!((alive_bits[l >> 3] >> (l & 7)) & 1)) {
          more = Die(L, l);  // position unchanged: the droplet dies where it is
        } else if (!((go_bits[l >> 3] >> (l & 7)) & 1)) {
          L.st->off_map_m3 += L.sed;
          more = false;
        } else {
          more = Apply(L, ix[l], iz[l], fx[l], fz[l], dy[l], cap[l], hnew[l]);
        }
        if (more) continue;
        if (Next(l)) continue;
        L.active = false;
        Park(l);
        --active;
      }
    }
  }

 private:
  struct Lane {
    double sed = 0;  // m³; double so that what a droplet carries balances what it moved
    int life = 0;
    bool active = false;
    const float* pos = nullptr;  // the current block's remaining droplet starts [pos, end)
    const float* end = nullptr;
    std::int32_t ox = 0, oz = 0;  // the block's origin in window cells
    HydraulicStats* st = nullptr;
    float* acc = nullptr;
  };

  float Height(float px, float pz, int ox, int oz) const {
    const int tx = int(px), tz = int(pz);
    const float fx = px - float(tx), fz = pz - float(tz);
    const float* p = k_.e + std::size_t(tz + oz) * k_.nx + (tx + ox);
    return p[0] * (1 - fx) * (1 - fz) + p[1] * fx * (1 - fz) + p[k_.nx] * (1 - fx) * fz + p[k_.nx + 1] * fx * fz;
  }

  // An idle lane computes at (0, 0) and is ignored.
  void Park(int l) { px_[l] = pz_[l] = dx_[l] = dz_[l] = 0, speed_[l] = water_[l] = 1, ox_[l] = oz_[l] = 0; }

  // Starts lane l's next droplet (from its tile, or from the next tile of the phase); false when
  // the phase has no more. Droplets starting in the sea are skipped.
  bool Next(int l) {
    Lane& L = lanes_[l];
    for (;;) {
      while (L.pos != L.end) {
        const float px = L.pos[0], pz = L.pos[1];
        L.pos += 2;
        if (Height(px, pz, L.ox, L.oz) < k_.sea) continue;
        ox_[l] = L.ox, oz_[l] = L.oz;
        px_[l] = px, pz_[l] = pz, dx_[l] = 0, dz_[l] = 0, speed_[l] = 1, water_[l] = 1;
        L.sed = 0, L.life = 0;
        ++L.st->droplets;
        return true;
      }
      const std::size_t j = next_->fetch_add(1, std::memory_order_relaxed);
      if (j >= njobs_) return false;
      L.pos = jobs_[j].pos, L.end = jobs_[j].pos + 2 * std::size_t(jobs_[j].n), L.st = jobs_[j].st;
      L.ox = jobs_[j].ox, L.oz = jobs_[j].oz;
    }
  }

  // Moves vol_m3 (m³, ≥ 0) with the brush centred on cell (ix, iz): deposits when `add` (heights
  // become min(old + want, 1)), else erodes (max(old − want, 0)). Returns the volume actually
  // moved (m³, ≥ 0). Branch-free in `add`: which of the two a step does is data-dependent.
  HWY_INLINE double Brush(Lane& L, int ix, int iz, float vol_m3, bool add) const {
    static constexpr float kInf = std::numeric_limits<float>::infinity();
    static constexpr float kSign[2] = {-1.0f, 1.0f}, kLo[2] = {0.0f, -kInf}, kHi[2] = {kInf, 1.0f};
    const float sign = kSign[add];
    const int R = k_.R;
    if (HWY_LIKELY(iz >= R && iz + R < k_.nz && ix >= R && ix + R < k_.nx)) {
      float* base = k_.e + std::size_t(iz - R) * k_.nx + (ix - R);
      const float vs = vol_m3 * sign, lo = kLo[add], hi = kHi[add];
      const hn::CappedTag<float, 8> d8;
      const int N = int(hn::Lanes(d8));
      // Full vectors stay inside the row; otherwise the same arithmetic one lane at a time.
      const float s = HWY_LIKELY(ix - R + (k_.w + N - 1) / N * N <= k_.nx)
                          ? BrushBox(d8, k_, base, vs, lo, hi, L.acc)
                          : BrushBox(hn::CappedTag<float, 1>(), k_, base, vs, lo, hi, L.acc);
      return double(s * sign) * k_.m3;
    }
    // Cut by the border: the weights are renormalised over the cells inside.
    double sum = 0;
    for (int c = 0; c < k_.ncells; ++c) {
      const int a = ix + k_.cell_di[c], b = iz + k_.cell_dj[c];
      if (a >= 0 && b >= 0 && a < k_.nx && b < k_.nz) sum += k_.cell_w[c];
    }
    double got = 0;
    for (int c = 0; c < k_.ncells; ++c) {
      const int a = ix + k_.cell_di[c], b = iz + k_.cell_dj[c];
      if (!(a >= 0 && b >= 0 && a < k_.nx && b < k_.nz)) continue;
      float* p = k_.e + std::size_t(b) * k_.nx + a;
      const float want = float(double(vol_m3) * k_.cell_w[c] / sum * k_.to_norm);
      const float old = *p, now = add ? std::min(old + want, 1.0f) : std::max(old - want, 0.0f);
      *p = now;
      got += add ? double(now - old) : double(old - now);
    }
    return got / k_.to_norm;
  }

  double DepositBilinear(int ix, int iz, float fx, float fz, float vol_m3) const {
    float* p = k_.e + std::size_t(iz) * k_.nx + ix;
    const float v = float(vol_m3 / k_.m3);
    float got = 0;
    auto put = [&](float* q, float amount) {
      const float old = *q, now = std::min(old + amount, 1.0f);
      *q = now;
      got += now - old;
    };
    put(p, v * (1 - fx) * (1 - fz));
    put(p + 1, v * fx * (1 - fz));
    put(p + k_.nx, v * (1 - fx) * fz);
    put(p + k_.nx + 1, v * fx * fz);
    return double(got) * k_.m3;
  }

  // The rest of a step that stays on the map: deposit or erode at the old cell (ix, iz) with
  // fraction (fx, fz), given the height change dy (m) and the capacity; then the droplet ends in
  // the sea or at the end of its life (the lane's position is already the new one). False when the
  // droplet ended (its totals are booked).
  bool Apply(Lane& L, int ix, int iz, float fx, float fz, float dy, float cap, float h_new) {
    HydraulicStats& st = *L.st;
    if (dy > 0) {
      const double got = DepositBilinear(ix, iz, fx, fz, std::min(dy * k_.cell2, float(L.sed)));
      L.sed -= got;
      st.deposited_m3 += got;
    } else {
      // Over capacity: deposit part of the excess; else erode.
      const float sed = float(L.sed);
      if (sed > cap) {
        const double got = DepositBilinear(ix, iz, fx, fz, (sed - cap) * k_.deposit);
        L.sed -= got;
        st.deposited_m3 += got;
      } else {
        const double got = Brush(L, ix, iz, std::min((cap - sed) * k_.erode, -dy * k_.area), false);
        L.sed += got;
        st.eroded_m3 += got;
      }
    }
    if (h_new < k_.sea) {
      st.to_sea_m3 += L.sed;
      return false;
    }
    if (++L.life == k_.lifetime) {
      const int l = int(&L - lanes_);
      return Die(L, l);
    }
    return true;
  }

  // The droplet dies on land at (px, pz): what it carries is deposited with the brush.
  bool Die(Lane& L, int l) {
    if (L.sed > 0) {
      const double got = Brush(L, int(px_[l]) + ox_[l], int(pz_[l]) + oz_[l], float(L.sed), true);
      L.st->deposited_m3 += got;
      L.st->stranded_m3 += L.sed - got;
    }
    return false;
  }

  const Kernel& k_;
  const TileJob* jobs_;
  std::size_t njobs_;
  std::atomic<std::size_t>* next_;
  Lane lanes_[kMax];
  HWY_ALIGN float px_[kMax], pz_[kMax], dx_[kMax], dz_[kMax], speed_[kMax], water_[kMax];
  HWY_ALIGN std::int32_t ox_[kMax] = {}, oz_[kMax] = {};
  hwy::AlignedFreeUniquePtr<float[]> acc_;
};

}  // namespace

void RunBatchImpl(const Kernel& k, const TileJob* jobs, std::size_t njobs, std::atomic<std::size_t>* next) {
  Batch(k, jobs, njobs, next).Run();
}

}  // namespace HWY_NAMESPACE
}  // namespace relief::erosion::kernel
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace relief::erosion {
namespace kernel {
HWY_EXPORT(RunBatchImpl);
void run_batch(const Kernel& k, const TileJob* jobs, std::size_t njobs, std::atomic<std::size_t>* next) {
  HWY_DYNAMIC_DISPATCH(RunBatchImpl)(k, jobs, njobs, next);
}
}  // namespace kernel

int hydraulic_reach_cells(const HydraulicSettings& s, double cell) {
  const double r = std::max(s.brush_radius_m, 1.5 * cell);
  return int(std::ceil(s.lifetime * s.step_m / cell)) + int(std::ceil(r / cell)) + 2;
}

HydraulicStats hydraulic_erosion(float* e, const Frame& f, const HydraulicSettings& s, std::uint64_t seed,
                                 const std::function<void(double)>& progress) {
  return hydraulic_erosion_part(e, f, s, seed, HydraulicPart{}, progress);
}

HydraulicStats hydraulic_erosion_part(float* e, const Frame& f, const HydraulicSettings& s, std::uint64_t seed,
                                      const HydraulicPart& part, const std::function<void(double)>& progress) {
  HydraulicStats total;
  if (f.nx < 2 || f.nz < 2) return total;
  const double cell = f.cell_m();
  // Droplets per world cell (the square between four samples): lambda on average, see erosion.hpp.
  const double lambda = s.droplets_per_km2 * cell * cell * 1e-6;
  const double wanted = lambda * double(f.nx - 1) * double(f.nz - 1);
  if (wanted > 4e8)
    throw Error("droplets_per_km2", "this window would need " + std::to_string(std::uint64_t(wanted)) +
                                        " droplets (at most 400000000); lower the density");
  const double lambda_whole = std::floor(lambda), lambda_frac = lambda - lambda_whole;

  // The brush covers at least the 3×3 cells around the droplet, so that on a coarse grid (cells
  // larger than the brush) a droplet's volume is not piled onto one cell. Weights ∝ (r − d).
  const double r = std::max(s.brush_radius_m, 1.5 * cell);
  const int radius_c = int(std::ceil(r / cell));
  std::vector<int> cdi, cdj;
  std::vector<double> cw;
  double sum = 0;
  int R = 0;
  for (int dj = -radius_c; dj <= radius_c; ++dj)
    for (int di = -radius_c; di <= radius_c; ++di) {
      const double dist = std::hypot(double(di), double(dj)) * cell;
      if (dist >= r) continue;
      cdi.push_back(di), cdj.push_back(dj), cw.push_back(r - dist);
      sum += r - dist;
      R = std::max({R, std::abs(di), std::abs(dj)});
    }
  for (double& w : cw) w /= sum;

  kernel::Kernel k;
  k.e = e;
  k.nx = f.nx, k.nz = f.nz;
  k.lifetime = s.lifetime;
  k.inertia = float(s.inertia), k.keep_dir = float(1 - s.inertia);
  k.capacity = float(s.capacity), k.min_capacity = float(s.min_capacity);
  k.erode = float(s.erode), k.deposit = float(s.deposit), k.evap_keep = float(1 - s.evaporate);
  k.gravity = float(s.gravity);
  k.gs = float(f.height_m / cell);
  k.H = float(f.height_m);
  k.cell2 = float(cell * cell);
  k.area = float(std::numbers::pi * s.brush_radius_m * s.brush_radius_m);
  k.step_c = float(s.step_m / cell);
  k.sea = float(f.sea_level);
  k.xlim = float(f.nx - 1), k.zlim = float(f.nz - 1);
  k.m3 = f.height_m * cell * cell;
  k.to_norm = 1.0 / (f.height_m * cell * cell);
  k.R = R, k.w = 2 * R + 1, k.P = (k.w + 7) / 8 * 8;
  hwy::AlignedFreeUniquePtr<float[]> box = hwy::AllocateAligned<float>(std::size_t(k.w) * k.P);
  std::fill(box.get(), box.get() + std::size_t(k.w) * k.P, 0.0f);
  for (std::size_t c = 0; c < cw.size(); ++c)
    box[std::size_t(cdj[c] + R) * k.P + (cdi[c] + R)] = float(cw[c] * k.to_norm);
  k.box = box.get();
  k.cell_di = cdi.data(), k.cell_dj = cdj.data(), k.cell_w = cw.data(), k.ncells = int(cw.size());

  // Blocks of side 2·reach cells, aligned on the WORLD's cell grid: a droplet never leaves reach
  // cells around its start (it moves step_m per step and erodes within the brush radius), so blocks
  // of one checkerboard colour never touch the same cells. A window's blocks are the world's blocks
  // cut by the window (still disjoint).
  const int reach = int(std::ceil(s.lifetime * s.step_m / cell)) + radius_c + 2;  // hydraulic_reach_cells()
  const std::int64_t B = 2 * std::int64_t(reach);
  const std::int64_t bx0 = f.ix0 / B, bz0 = f.iz0 / B;
  const int ntx = int((f.ix0 + f.nx - 2) / B - bx0 + 1), ntz = int((f.iz0 + f.nz - 2) / B - bz0 + 1);
  const std::size_t ntiles = std::size_t(ntx) * ntz;
  // Each block's droplets: start positions in window cells (x, z interleaved), sorted by their order
  // key; round r holds [start[r], start[r + 1]) (in droplets).
  constexpr int kRounds = 4;
  const int pass0 = std::clamp(part.first_pass, 0, 4 * kRounds);
  const int pass1 = std::clamp(part.first_pass + std::max(0, part.passes), pass0, 4 * kRounds);
  unsigned rounds_wanted = 0, phases_wanted = 0;  // bit masks
  for (int p = pass0; p < pass1; ++p) rounds_wanted |= 1u << (p / 4), phases_wanted |= 1u << (p % 4);
  struct Block {
    std::vector<float> pos;
    std::uint32_t start[kRounds + 1] = {};
    std::int32_t ox = 0, oz = 0;
  };
  std::vector<Block> blocks(ntiles);
  tbb::parallel_for(std::size_t(0), ntiles, [&](std::size_t t) {
    const std::int64_t tx = std::int64_t(t % std::size_t(ntx)), tz = std::int64_t(t / std::size_t(ntx));
    const int i0 = int(std::max<std::int64_t>(0, (bx0 + tx) * B - f.ix0));
    const int i1 = int(std::min<std::int64_t>(f.nx - 1, (bx0 + tx + 1) * B - f.ix0));
    const int j0 = int(std::max<std::int64_t>(0, (bz0 + tz) * B - f.iz0));
    const int j1 = int(std::min<std::int64_t>(f.nz - 1, (bz0 + tz + 1) * B - f.iz0));
    // Block coordinates: window cell (i, j) is at (i − ox, j − oz); the block's cells at reach .. reach + B.
    const std::int64_t ox = (bx0 + tx) * B - reach - f.ix0, oz = (bz0 + tz) * B - reach - f.iz0;
    Block& bl = blocks[t];
    bl.ox = std::int32_t(ox), bl.oz = std::int32_t(oz);
    // Blocks and droplets that no selected pass runs are skipped (HydraulicPart).
    const std::int64_t wbx = bx0 + tx, wbz = bz0 + tz;
    if (wbx < part.bx0 || wbx >= part.bx1 || wbz < part.bz0 || wbz >= part.bz1 ||
        !((phases_wanted >> (int(wbx & 1) + 2 * int(wbz & 1))) & 1))
      return;
    struct Start {
      std::uint64_t key;
      int j, i, k;
      float px, pz;
    };
    std::vector<Start> starts;
    for (int j = j0; j < j1; ++j)
      for (int i = i0; i < i1; ++i) {
        const std::uint64_t base =
            hash64(hash64(seed, std::uint64_t(f.ix0 + i)), std::uint64_t(f.iz0 + j));
        const int n = int(lambda_whole) + (unit_double(hash64(base, 0x6e)) < lambda_frac ? 1 : 0);
        for (int d = 0; d < n; ++d) {
          const std::uint64_t hk = hash64(base, std::uint64_t(d));
          const std::uint64_t key = hash64(hk, 0x6f);
          if (!((rounds_wanted >> int(key >> 62)) & 1)) continue;
          // Below the cell's far corner (float rounding could reach it).
          const float xe = float(i + 1 - ox), ze = float(j + 1 - oz);
          const float px = std::min(float(double(i - ox) + unit_double(hash64(hk, 0x78))), std::nextafter(xe, 0.0f));
          const float pz = std::min(float(double(j - oz) + unit_double(hash64(hk, 0x7a))), std::nextafter(ze, 0.0f));
          starts.push_back({key, j, i, d, px, pz});
        }
      }
    // The order key's top two bits are the round; the rest shuffles the block's droplets. Ties
    // (never seen in practice) by world cell, row-major, then by index in the cell.
    std::sort(starts.begin(), starts.end(), [](const Start& a, const Start& b) {
      if (a.key != b.key) return a.key < b.key;
      if (a.j != b.j) return a.j < b.j;
      if (a.i != b.i) return a.i < b.i;
      return a.k < b.k;
    });
    bl.pos.resize(2 * starts.size());
    int r = 0;
    for (std::size_t q = 0; q < starts.size(); ++q) {
      bl.pos[2 * q] = starts[q].px, bl.pos[2 * q + 1] = starts[q].pz;
      while (int(starts[q].key >> 62) > r) bl.start[++r] = std::uint32_t(q);
    }
    while (r < kRounds) bl.start[++r] = std::uint32_t(starts.size());
  });
  std::vector<HydraulicStats> per_tile(ntiles);
  // Each round runs one round of every block's droplets; each phase one checkerboard colour of the
  // world's blocks. The blocks of a phase touch disjoint cells, so they may run in any order on
  // any thread, each block's droplets in key order in one lane: every thread pulls the next block
  // from a shared counter, the largest first so that lanes run out of work together.
  const int workers = std::max(1, tbb::this_task_arena::max_concurrency());
  std::vector<kernel::TileJob> jobs;
  for (int pass = pass0; pass < pass1; ++pass) {
    const int round = pass / 4, phase = pass % 4;
    {
      jobs.clear();
      for (int tz = 0; tz < ntz; ++tz)
        for (int tx = 0; tx < ntx; ++tx) {
          if (int((bx0 + tx) & 1) + 2 * int((bz0 + tz) & 1) != phase) continue;
          const std::size_t t = std::size_t(tz) * ntx + tx;
          const Block& bl = blocks[t];
          const std::uint32_t lo = bl.start[round], hi = bl.start[round + 1];
          if (hi > lo) jobs.push_back({bl.pos.data() + 2 * std::size_t(lo), hi - lo, &per_tile[t], bl.ox, bl.oz});
        }
      std::stable_sort(jobs.begin(), jobs.end(), [](const kernel::TileJob& a, const kernel::TileJob& b) { return a.n > b.n; });
      std::atomic<std::size_t> next{0};
      tbb::parallel_for(0, workers, [&](int) { kernel::run_batch(k, jobs.data(), jobs.size(), &next); });
      if (progress) progress(double(pass - pass0 + 1) / double(pass1 - pass0));
    }
  }
  for (const auto& st : per_tile) {
    total.eroded_m3 += st.eroded_m3;
    total.deposited_m3 += st.deposited_m3;
    total.to_sea_m3 += st.to_sea_m3;
    total.off_map_m3 += st.off_map_m3;
    total.stranded_m3 += st.stranded_m3;
    total.droplets += st.droplets;
  }
  return total;
}

}  // namespace relief::erosion
#endif  // HWY_ONCE
