#pragma once
// Internal: monotone cubic Hermite curves (F. N. Fritsch, R. E. Carlson, "Monotone Piecewise Cubic
// Interpolation", SIAM J. Numer. Anal. 17(2), 1980). Used by the `curve` stage and by each biome
// type's animation-curve remap.
#include <algorithm>
#include <cmath>
#include <vector>

#include "relief/params.hpp"

namespace relief::detail {

// Fritsch–Carlson tangents for control points with strictly increasing x (at least 2 points).
inline std::vector<double> monotone_tangents(const std::vector<CurvePoint>& c) {
  const std::size_t n = c.size();
  std::vector<double> delta(n - 1), m(n);
  for (std::size_t k = 0; k + 1 < n; ++k) delta[k] = (c[k + 1].y - c[k].y) / (c[k + 1].x - c[k].x);
  m[0] = delta[0];
  m[n - 1] = delta[n - 2];
  for (std::size_t k = 1; k + 1 < n; ++k)
    m[k] = (delta[k - 1] * delta[k] <= 0.0) ? 0.0 : 0.5 * (delta[k - 1] + delta[k]);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    if (delta[k] == 0.0) {
      m[k] = m[k + 1] = 0.0;
      continue;
    }
    const double a = m[k] / delta[k], b = m[k + 1] / delta[k];
    const double r2 = a * a + b * b;
    if (r2 > 9.0) {  // project onto the circle of radius 3: sufficient for monotonicity
      const double tau = 3.0 / std::sqrt(r2);
      m[k] = tau * a * delta[k];
      m[k + 1] = tau * b * delta[k];
    }
  }
  return m;
}

// Value at x: first/last y outside the control points' x range; never overshoots a segment's
// end values (a flat segment is exactly flat).
inline double eval_curve(const std::vector<CurvePoint>& c, const std::vector<double>& m, double x) {
  if (x <= c.front().x) return c.front().y;
  if (x >= c.back().x) return c.back().y;
  // First k with c[k+1].x > x.
  std::size_t k = std::size_t(std::upper_bound(c.begin(), c.end(), x, [](double v, const CurvePoint& p) { return v < p.x; }) -
                              c.begin()) - 1;
  const double h = c[k + 1].x - c[k].x, s = (x - c[k].x) / h;
  const double s2 = s * s, s3 = s2 * s;
  const double y = (2 * s3 - 3 * s2 + 1) * c[k].y + (s3 - 2 * s2 + s) * h * m[k] + (-2 * s3 + 3 * s2) * c[k + 1].y +
                   (s3 - s2) * h * m[k + 1];
  // Exact no-overshoot guarantee (the tangents make it hold mathematically; this removes rounding).
  return std::clamp(y, std::min(c[k].y, c[k + 1].y), std::max(c[k].y, c[k + 1].y));
}

// A curve with its tangents computed once.
struct Curve {
  std::vector<CurvePoint> points;
  std::vector<double> tangents;
  explicit Curve(std::vector<CurvePoint> p) : points(std::move(p)), tangents(monotone_tangents(points)) {}
  double operator()(double x) const { return eval_curve(points, tangents, x); }
};

}  // namespace relief::detail
