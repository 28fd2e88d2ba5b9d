#pragma once
// The stream power kernel on a window of a larger map (world_stream_power's refinement,
// src/world_bounded.cpp, issue 18), for the library and its tests; not part of the public API.
#include <cstdint>
#include <functional>

#include "relief/erosion.hpp"
#include "relief/params.hpp"

namespace relief::erosion::detail {

// What a window needs from the map around it. The window's outer ring (the cells on its border) stays
// the solver's outlets, as in stream_power, but its heights are the map's, step by step, and the
// drainage area that enters the window from outside is added where it enters. Heights are the
// solver's: metres above the sea surface, h = (e − sea_level) · height_m, nx · nz doubles, row-major.
struct StreamPowerWindow {
  // Writes the ring's heights (it may read all of h, and must write nothing else): at the start of
  // step `step` with after = false (the levels the step's D8 pass and lake fill see: the map's heights
  // after the previous step and this step's fill), and after the step's uplift with after = true (the
  // levels the step ends at, against which the cells draining into the ring are solved). Empty: the
  // ring keeps its input heights (stream_power's behaviour).
  std::function<void(int step, bool after, double* h)> ring;
  // Drainage area, in cells of the window, entering from outside at step `step` (after its D8 pass):
  // added to the cell's own area, and so to every cell downstream. `extra` (nx · nz) is zeroed before
  // each call. Empty: no inflow.
  std::function<void(int step, double* extra)> inflow;
  // Observers: h after the step's D8 pass and fill (the levels D8 saw), and after the solve; the
  // step's D8 direction codes (hydro::d8_directions) and drainage areas in cells (with the inflow),
  // after the solve. An outlet that nothing drains into this step keeps the area of the last step
  // where something did (0 if none): read areas only where a receiver exists.
  std::function<void(int step, const double* h)> seen, solved;
  std::function<void(int step, const std::uint8_t* dir, const double* area)> routed;
};

// The stream_power stage's resolved params (Stage::params(): its table in src/stage_erosion.cpp, read
// as the stage reads them; keys that are not the table's, such as a masked stage's, are ignored) as
// the kernel's settings: the one conversion the stage and world_stream_power's refinement share.
StreamPowerSettings stream_power_settings(const json& params);

// stream_power (relief/erosion.hpp) on a window with the map's levels on its ring and the map's
// inflow. With an empty StreamPowerWindow it is stream_power, bit for bit. Given the map's input as the
// map's solver starts from it (filled: fill_depressions with ε = 0, which the window's own first fill
// then leaves as it is), the whole map's own ring levels (seen and solved) and inflow (the whole map's
// drainage area of ring cells that drain into the window's inside), the window's inside reproduces the
// whole map's bit for bit, lakes that cross the ring included (tests/test_erosion.cpp: a 129² island;
// the 16 windows of blocks of 128 grown by 32 on the 513² eroded-mountains world, every one cutting
// lakes of the map's first fill). Every step's lake fill may hold the whole ring as outlets: the map's
// filled levels restricted to the window solve the window's fill equation, and a lower solution would
// give a lower one on the whole map. Given the raw input instead, the window's own first fill drains a
// lake that crosses the ring across the ring at the ring's raw levels, and the inside differs (there:
// 253806 of 490000 samples, by up to 10 % of the relief; the cause of world_stream_power's error at
// 1025² before its input was filled across tiles).
StreamPowerStats stream_power_window(float* e, const Frame& f, const StreamPowerSettings& s, const StreamPowerWindow& w,
                                     const std::function<void(double)>& progress = {});

}  // namespace relief::erosion::detail
