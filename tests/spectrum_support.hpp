#pragma once
// Spectral helpers shared by the noise tests (test_noise_simd.cpp, test_noise3.cpp): an FFT for
// radially averaged power spectra and the Kolmogorov–Smirnov distance between two of them.
#include <algorithm>
#include <cmath>
#include <complex>
#include <utility>
#include <vector>

namespace relief::test {

// In-place radix-2 FFT (Cooley–Tukey, iterative), n a power of two: enough for a test's spectra.
inline void fft(std::vector<std::complex<double>>& a) {
  const std::size_t n = a.size();
  for (std::size_t i = 1, j = 0; i < n; ++i) {
    std::size_t bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(a[i], a[j]);
  }
  for (std::size_t len = 2; len <= n; len <<= 1) {
    const std::complex<double> w = std::polar(1.0, -2.0 * M_PI / double(len));
    for (std::size_t i = 0; i < n; i += len) {
      std::complex<double> wk = 1.0;
      for (std::size_t k = 0; k < len / 2; ++k, wk *= w) {
        const std::complex<double> u = a[i + k], v = a[i + k + len / 2] * wk;
        a[i + k] = u + v;
        a[i + k + len / 2] = u - v;
      }
    }
  }
}

// The power of an n × n patch whose rows already went through fft(), binned by radius: the columns
// are transformed here, and bin r (local.size() ≥ n/2 + 1) gains the power of the wave vectors with
// round(|k|) = r cycles per patch (|k| ≤ n/2). Returns the power binned.
inline double radial_power(const std::vector<std::vector<std::complex<double>>>& rows, std::vector<double>& local) {
  const int n = int(rows.size());
  std::vector<std::complex<double>> col(static_cast<std::size_t>(n));
  double total = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) col[std::size_t(j)] = rows[std::size_t(j)][std::size_t(i)];
    fft(col);
    for (int j = 0; j < n; ++j) {
      const int kx = i <= n / 2 ? i : i - n, kz = j <= n / 2 ? j : j - n;
      const int r = int(std::lround(std::sqrt(double(kx * kx + kz * kz))));
      if (r > n / 2) continue;
      const double pw = std::norm(col[std::size_t(j)]);
      local[std::size_t(r)] += pw;
      total += pw;
    }
  }
  return total;
}

// Largest difference between two cumulative power distributions (a Kolmogorov–Smirnov distance).
inline double ks(const std::vector<double>& a, const std::vector<double>& b) {
  double ca = 0, cb = 0, worst = 0;
  for (std::size_t r = 0; r < a.size() && r < b.size(); ++r) {
    ca += a[r];
    cb += b[r];
    worst = std::max(worst, std::fabs(ca - cb));
  }
  return worst;
}

}  // namespace relief::test
