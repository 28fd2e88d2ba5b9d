#include "relief/terrain.hpp"

#include <cstdint>

#include "relief/error.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace relief {

namespace {

// Hands the smallest spare buffer whose capacity holds `want` floats to `data` (if `data`'s own
// capacity is too small and there is one).
void take_spare(std::vector<std::vector<float>>& spare, std::vector<float>& data, std::size_t want) {
  if (data.capacity() >= want) return;
  auto best = spare.end();
  for (auto it = spare.begin(); it != spare.end(); ++it)
    if (it->capacity() >= want && (best == spare.end() || it->capacity() < best->capacity())) best = it;
  if (best != spare.end()) {
    data.swap(*best);
    detail::cache_buffer(std::move(*best));  // the layer's old buffer, if large enough to keep
    spare.erase(best);
  }
}

// Reserves room for `want` floats in an empty vector and asks for transparent huge pages over the
// whole 2 MiB pages inside it, before anything touches it (a hint: without THP nothing changes).
void reserve_huge(std::vector<float>& data, std::size_t want) {
  constexpr std::size_t kHuge = std::size_t(2) << 20;
  detail::cache_buffer(std::move(data));  // the old buffer (too small): to the cache or freed
  data.reserve(want);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  const auto begin = reinterpret_cast<std::uintptr_t>(data.data());
  const std::uintptr_t first = (begin + kHuge - 1) & ~std::uintptr_t(kHuge - 1);
  const std::uintptr_t last = (begin + want * sizeof(float)) & ~std::uintptr_t(kHuge - 1);
  if (last > first) (void)madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
#endif
}

// Gives `data` room for `want` floats: its own buffer, else the smallest spare one that holds them,
// else (4 MiB or more) one of the process-wide cache, else a new one (huge pages asked for when
// 4 MiB or more). Values are stale except in a new buffer.
void provide(std::vector<std::vector<float>>& spare, std::vector<float>& data, std::size_t want) {
  if (data.capacity() >= want) return;
  take_spare(spare, data, want);
  if (want * sizeof(float) < kLayerCacheMinBytes) return;
  if (data.capacity() >= want) {
    detail::note_buffer_request(want);  // the cache may keep this buffer when the layer gives it up
    return;
  }
  if (!detail::take_cached_buffer(data, want)) reserve_huge(data, want);
}

}  // namespace

Layer::Layer(const Layer& o) : channels(o.channels) {
  detail::take_cached_buffer(data, o.data.size());
  data.assign(o.data.begin(), o.data.end());
}

Layer& Layer::operator=(const Layer& o) {
  if (this == &o) return *this;
  channels = o.channels;
  // A large enough buffer of the cache, or the cache keeps the old one that assign() would free.
  if (data.capacity() < o.data.size() && !detail::take_cached_buffer(data, o.data.size()))
    detail::cache_buffer(std::move(data));
  data.assign(o.data.begin(), o.data.end());
  return *this;
}

Layer& Terrain::layer(const std::string& name, int channels) {
  Layer& l = layers[name];
  const std::size_t want = frame.count() * std::size_t(channels);
  if (l.channels != channels || l.data.size() != want) {
    l.channels = channels;
    provide(spare, l.data, want);
    l.data.assign(want, 0.0f);
  }
  return l;
}

Layer& Terrain::layer_for_overwrite(const std::string& name, int channels) {
  Layer& l = layers[name];
  const std::size_t want = frame.count() * std::size_t(channels);
  l.channels = channels;
  if (l.data.size() == want) return l;
  provide(spare, l.data, want);
  l.data.resize(want);  // writes only the elements added beyond the old size
  return l;
}

const Layer& Terrain::get(const std::string& name) const {
  auto it = layers.find(name);
  if (it == layers.end()) throw Error("", "layer '" + name + "' is missing: an earlier stage must write it");
  return it->second;
}

Layer& Terrain::get(const std::string& name) {
  return const_cast<Layer&>(static_cast<const Terrain&>(*this).get(name));
}

}  // namespace relief
