#pragma once
// Internal: deterministic row-parallel loops on oneTBB.
//
// Work is split into fixed row blocks; every row is computed by exactly the same code whatever
// the thread count, so results are byte-identical for 1..N threads. The thread count is set by
// the caller with a tbb::global_control (see pipeline.cpp / RunOptions::threads).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace relief::detail {

// Calls fn(j) for every row j in [0, rows). fn must only write data owned by row j.
template <class F>
void parallel_rows(int rows, F&& fn, int grain = 4) {
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, grain), [&](const tbb::blocked_range<int>& r) {
    for (int j = r.begin(); j < r.end(); ++j) fn(j);
  });
}

}  // namespace relief::detail
