#pragma once
// Grid hydrology (depression filling, D8 receivers, flow order) shared by the erosion stages,
// `relief bench` and the tests.
//
// Index space: cell c = j·nx + i of an nx × nz grid (row-major, x fastest), the same as a Layer.
// Neighbours are the 8 cells around c (D8). A cell is an *outlet* (base level) when it lies on the
// border of the grid or below the sea (`z < sea`): water reaching an outlet leaves the map or
// enters the sea. Everything here is sequential or row-parallel with per-cell arithmetic that does
// not depend on scheduling, so results are identical for any thread count.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace relief::hydro {

// Neighbour k of 8 (E, SE, S, SW, W, NW, N, NE): offsets and distances in cells.
inline constexpr int kDi[8] = {1, 1, 0, -1, -1, -1, 0, 1};
inline constexpr int kDj[8] = {0, 1, 1, 1, 0, -1, -1, -1};
inline constexpr double kDist[8] = {1.0, 1.4142135623730951, 1.0, 1.4142135623730951,
                                    1.0, 1.4142135623730951, 1.0, 1.4142135623730951};

inline bool on_border(int i, int j, int nx, int nz) { return i == 0 || j == 0 || i == nx - 1 || j == nz - 1; }

// Priority-Flood+ε depression filling (Barnes, Lehman, Mulla 2014, Algorithm 3), with the slope
// traversal of Zhou, Sun, Fu 2016 (cells met uphill of the flood front are final at once and only
// enter the priority queue when they border lower unvisited cells), the queue filter of Wei, Zhou,
// Fu 2018 (such a cell is queued only when a lower unvisited neighbour has no spill path) and a
// monotone radix heap (Ahuja, Mehlhorn, Orlin, Tarjan 1990) keyed on the order-preserving bits of
// the elevation.
//
// The filled surface F is defined, independently of any processing order, as the least solution of
//     F(c) = z(c)                                        for outlets (border, or z < sea),
//     F(c) = min over the 8 neighbours n of g(F(n), z(c))  otherwise,
//     g(L, z) = z when z > L, else step(L),   step(L) = max(L + ε, the next value above L).
// So: values only rise; a cell with a lower neighbour on a path that descends to an outlet keeps
// its value; a cell inside a depression or on a flat is raised to step(level) of the cell it
// drains to, so filled flats get a gradient of at least `epsilon` (≥ 0, in the units of z) per
// cell towards the spill point; every non-outlet cell ends strictly above a neighbour through which
// it drains, step by step, to an outlet. The traversal settles levels in non-decreasing order
// (Dijkstra's order, which finds the least solution: Knuth 1977), and equal levels may settle in
// any order without changing a bit — which is what lets a tiled world reproduce the whole map's
// result exactly (fill_depressions_tile below, relief/world.hpp).
//
// `z` (nx·nz values, any finite values) is raised in place to F. nx, nz ≥ 1.
template <class T>
void fill_depressions(T* z, int nx, int nz, T sea, T epsilon);

// One tile of a tiled fill (Barnes 2016's Parallel Priority-Flood, exchanging tile borders): the
// least solution of the same equation restricted to paths inside the nx × nz tile, where
// `outlet[c]` ≠ 0 marks the cells fixed at z (the world's border and the sea; a tile's own border
// is not an outlet unless the world's is) and `seed[c]` (+inf: none) is a level that some path
// outside the tile gives c (an upper bound of F(c), as a neighbouring tile's solve found it). On
// return z[c] holds the least level any path inside the tile (from an outlet or a seed) gives c, or
// +inf when no such path reaches c. Solving every tile again with the border levels its neighbours
// found, until no border level changes, gives fill_depressions' result on the whole world, bit for
// bit (src/world_fill.cpp).
template <class T>
void fill_depressions_tile(T* z, int nx, int nz, const std::uint8_t* outlet, const T* seed, T epsilon);

// True when fill_depressions(z, nx, nz, sea, ε) would change no value, for any ε: every cell that
// is not an outlet (map border, or below `sea`) has a strictly lower neighbour. So a surface that
// an earlier `fill` left drains as it is. One row-parallel pass over the lowest neighbour of each
// cell, stopping early once a row fails; never changes z.
template <class T>
bool already_drains(const T* z, int nx, int nz, T sea);

// D8 steepest descent: rec[c] = the neighbour with the largest drop / distance, if that drop is
// > 0; rec[c] = c for outlets and for pits (no lower neighbour). Ties go to the first neighbour in
// the order E, SE, S, SW, W, NW, N, NE. Row-parallel, Highway SIMD (src/hydrology_d8.cpp; every
// target picks the same receivers).
template <class T>
void d8_receivers(const T* z, int nx, int nz, T sea, std::uint32_t* rec);

// The same choice as a direction code per cell: dir[c] = k when the receiver is the neighbour
// (i + kDi[k], j + kDj[k]), kNoReceiver for outlets and pits. Returns the number of pits (cells
// that are not outlets and have no strictly lower neighbour, as count_pits counts them).
inline constexpr std::uint8_t kNoReceiver = 8;
template <class T>
std::size_t d8_directions(const T* z, int nx, int nz, T sea, std::uint8_t* dir);

// Donor masks of direction codes: bit k of mask[c] is set when the neighbour (i + kDi[k],
// j + kDj[k]) drains into c (its code is (k + 4) mod 8). Row-parallel. With them the flow graph can
// be walked upstream from any outlet without building donor lists (Braun and Willett 2013's stack,
// breadth first).
void donor_masks(const std::uint8_t* dir, int nx, int nz, std::uint8_t* mask);

// A topological order of the flow graph, donors before receivers: every cell appears after all
// cells that drain into it (Kahn 1962, following chains downstream from the sources). `rec` must
// be acyclic apart from self-loops (true for receivers of d8_receivers). Fills `order` with all
// n cells. If `count` is not null it receives the number of cells draining through each cell,
// itself included (the drainage area in cells).
void flow_order(const std::uint32_t* rec, std::size_t n, std::vector<std::uint32_t>& order,
                std::uint32_t* count = nullptr);

// Number of cells that are not outlets and have no strictly lower neighbour.
template <class T>
std::size_t count_pits(const T* z, int nx, int nz, T sea);

}  // namespace relief::hydro
