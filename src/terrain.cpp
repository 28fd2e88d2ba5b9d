#include "relief/terrain.hpp"

#include "relief/error.hpp"

namespace relief {

Layer& Terrain::layer(const std::string& name, int channels) {
  Layer& l = layers[name];
  const std::size_t want = frame.count() * std::size_t(channels);
  if (l.channels != channels || l.data.size() != want) {
    l.channels = channels;
    if (l.data.capacity() < want) {
      // The smallest spare buffer that holds the layer, if any.
      auto best = spare.end();
      for (auto it = spare.begin(); it != spare.end(); ++it)
        if (it->capacity() >= want && (best == spare.end() || it->capacity() < best->capacity())) best = it;
      if (best != spare.end()) {
        l.data.swap(*best);
        spare.erase(best);
      }
    }
    l.data.assign(want, 0.0f);
  }
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
