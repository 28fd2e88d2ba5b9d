#pragma once
// The one parameter table.
//
// Each stage (and the recipe's `world` block) declares its parameters once, as a list of
// Field<P> bound to members of a plain params struct P. That list alone drives:
//   * parsing and validation of recipe JSON (errors name `stages[i].field`),
//   * defaults (taken from a default-constructed P),
//   * `--set` overrides (applied to the recipe JSON, then parsed by the same table),
//   * `relief explain`, the studio's generated controls and the docs (via ParamInfo::to_json).
// Nothing re-declares a parameter by hand elsewhere.
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "relief/error.hpp"

namespace relief {

using json = nlohmann::ordered_json;

// Names: a list of strings; List: a list of records, each read by its own table (ParamInfo::fields).
enum class ParamType { Int, Float, Bool, Choice, Color, Curve, Levels, Text, Names, List, IntList };
// What a change to the parameter invalidates: the heights (regenerate) or only the colours.
enum class Effect { Regenerate, Recolour };

struct Rgb {
  float r = 0, g = 0, b = 0;  // 0..1
  bool operator==(const Rgb&) const = default;
};
// 0xRRGGBB as an Rgb, each channel / 255 (the colour tables of the stages).
constexpr Rgb rgb_hex(std::uint32_t v) {
  return Rgb{float((v >> 16) & 255) / 255.0f, float((v >> 8) & 255) / 255.0f, float(v & 255) / 255.0f};
}
// A colour level: elevation (or other value) threshold and its colour. Optional texture image:
// a PNG file tiled every `tile_m` metres in world x/z (a relative name is the recipe file's
// folder's when the recipe was read by read_recipe_file, else the working directory's),
// used instead of the flat colour; a missing or undecodable file is an Error naming the level.
struct Level {
  double at = 0;
  Rgb color;
  std::string name;
  std::string texture;  // "" = flat colour
  double tile_m = 64;   // texture repeat in metres (only with a texture)
  bool operator==(const Level&) const = default;
};
struct CurvePoint {
  double x = 0, y = 0;
  bool operator==(const CurvePoint&) const = default;
};

struct ParamInfo {
  std::string name;
  ParamType type = ParamType::Float;
  json default_value;
  double min = 0, max = 0;  // inclusive range for Int/Float (and element ranges for Curve/Levels)
  std::string unit;         // "m", "deg", "" …
  std::string description;  // one line
  std::vector<std::string> choices;  // for Choice
  Effect effect = Effect::Regenerate;
  std::vector<ParamInfo> fields;     // for List: the parameters of each record
  std::vector<double> values;        // Int/Float: when not empty, the only accepted values (min..max spans them)
  json to_json() const;  // {name, type, default, min, max, values, unit, description, choices, effect, fields}
};

const char* to_string(ParamType t);

template <class P>
struct Field {
  ParamInfo info;
  std::function<void(P&, const json&, const std::string& path)> read;  // validates, throws Error
  std::function<json(const P&)> write;
};

// ---- user text in messages -------------------------------------------------------------------
// Deepest nesting of arrays and objects a JSON document may have (recipes, presets, `--set`
// values, studio request bodies). Real recipes nest 4 levels; the limit keeps every recursive
// walk of a document (copies, comparisons, dumps) far from the stack's end.
constexpr int kMaxJsonDepth = 128;
// Parses JSON text with that limit. Throws Error(path, ORIGIN + " is not valid JSON: …") on a
// syntax error and Error(path, ORIGIN + " nests deeper than 128 levels …") past the limit.
json parse_json(std::string_view text, const std::string& origin, const std::string& path = "");
// The depth check alone (for text that may also be read as a plain string, as `--set` values).
void check_json_depth(std::string_view text, const std::string& origin, const std::string& path = "");
// User text for a message: in double quotes, JSON-escaped (control characters as \n, \u0000),
// invalid UTF-8 replaced by U+FFFD, cut after `max_bytes` bytes (at a character boundary,
// marked "..."). Always valid UTF-8, never longer than max_bytes + 5.
std::string quote(std::string_view text, std::size_t max_bytes = 60);
// True when `text` is well-formed UTF-8 (RFC 3629), as every string of a json must be to be dumped.
bool is_utf8(std::string_view text);

// ---- value readers (throw relief::Error naming `path`) ------------------------------------
// Short human form of a JSON value for messages ("a string \"abc\"", "an array [1, 2]"):
// bounded in length (about 60 bytes) and depth whatever the value, valid UTF-8.
std::string describe(const json& v);
std::int64_t read_int(const json& v, const std::string& path, double min, double max);
double read_float(const json& v, const std::string& path, double min, double max);
bool read_bool(const json& v, const std::string& path);
std::string read_choice(const json& v, const std::string& path, const std::vector<std::string>& choices);
Rgb read_color(const json& v, const std::string& path);  // "#rrggbb" or [r,g,b] in 0..255
json write_color(const Rgb& c);  // "#rrggbb" when exact, else [r, g, b] in 0..255 (every bit kept)
std::vector<CurvePoint> read_curve(const json& v, const std::string& path, double min, double max);
std::vector<Level> read_levels(const json& v, const std::string& path, double min, double max);
json write_levels(const std::vector<Level>& l);
std::vector<std::string> read_names(const json& v, const std::string& path);  // ["a", …], each non-empty
// Closest name by edit distance, for "did you mean" hints ("" if nothing is close).
std::string nearest_name(const std::string& given, const std::vector<std::string>& names);

// ---- field builders ------------------------------------------------------------------------
// A field with its metadata and no reader or writer yet: where every builder below starts.
template <class P>
Field<P> field_info(std::string name, ParamType type, std::string description, Effect effect, double min = 0,
                    double max = 0) {
  Field<P> f;
  f.info.name = std::move(name);
  f.info.type = type;
  f.info.min = min;
  f.info.max = max;
  f.info.description = std::move(description);
  f.info.effect = effect;
  return f;
}

// A field whose value is read by `read(json, path)` (validating, throwing Error naming `path`) and
// written by `write(value)`: what every builder below but the numbers and choices is.
template <class P, class T, class Read, class Write>
Field<P> bound(T P::*m, std::string name, ParamType type, std::string description, Effect effect, double min, double max,
               Read read, Write write) {
  Field<P> f = field_info<P>(std::move(name), type, std::move(description), effect, min, max);
  f.read = [m, read](P& p, const json& v, const std::string& path) { p.*m = read(v, path); };
  f.write = [m, write](const P& p) { return json(write(p.*m)); };
  return f;
}

// Numbers and booleans: the type follows the member (int / std::int64_t / double / bool).
template <class P, class T>
Field<P> param(T P::*m, std::string name, double min, double max, std::string unit, std::string description,
               Effect effect = Effect::Regenerate) {
  Field<P> f = field_info<P>(std::move(name), ParamType::Float, std::move(description), effect, min, max);
  f.info.unit = std::move(unit);
  if constexpr (std::is_same_v<T, bool>) {
    f.info.type = ParamType::Bool;
    f.read = [m](P& p, const json& v, const std::string& path) { p.*m = read_bool(v, path); };
  } else if constexpr (std::is_integral_v<T>) {
    f.info.type = ParamType::Int;
    f.read = [m, min, max](P& p, const json& v, const std::string& path) { p.*m = T(read_int(v, path, min, max)); };
  } else {
    static_assert(std::is_floating_point_v<T>);
    f.info.type = ParamType::Float;
    f.read = [m, min, max](P& p, const json& v, const std::string& path) { p.*m = T(read_float(v, path, min, max)); };
  }
  f.write = [m](const P& p) { return json(p.*m); };
  return f;
}

// A choice read into an enum: `choices` maps each value to the one string recipes, `--set`, the
// resolved recipe, `relief explain` and the studio use. Unknown strings are refused at parse time
// (Error naming `path`, with a "did you mean"), so stage code only ever sees valid enum values and
// never compares strings.
template <class E>
using ChoiceNames = std::vector<std::pair<E, std::string>>;

// The string of `v` in `names` (every enum value a table can hold is listed, so this never fails).
template <class E>
const std::string& choice_name(const ChoiceNames<E>& names, E v) {
  for (auto& [e, s] : names)
    if (e == v) return s;
  return names.front().second;  // unreachable for values read through the table
}

template <class P, class E>
  requires std::is_enum_v<E>
Field<P> choice(E P::*m, std::string name, ChoiceNames<E> names, std::string description,
                Effect effect = Effect::Regenerate) {
  Field<P> f = field_info<P>(std::move(name), ParamType::Choice, std::move(description), effect);
  for (auto& n : names) f.info.choices.push_back(n.second);
  auto shared = std::make_shared<const ChoiceNames<E>>(std::move(names));
  f.read = [m, shared, strings = f.info.choices](P& p, const json& v, const std::string& path) {
    const std::string s = read_choice(v, path, strings);
    for (auto& [e, n] : *shared)
      if (n == s) p.*m = e;
  };
  f.write = [m, shared](const P& p) { return json(choice_name(*shared, p.*m)); };
  return f;
}

template <class P>
Field<P> text(std::string P::*m, std::string name, std::string description, Effect effect = Effect::Regenerate) {
  return bound(
      m, std::move(name), ParamType::Text, std::move(description), effect, 0, 0,
      [](const json& v, const std::string& path) {
        if (!v.is_string()) throw Error(path, "expected a string, got " + describe(v));
        return v.get<std::string>();
      },
      [](const std::string& t) { return t; });
}

// A list of names ["plains", "forest"] (each a non-empty string; the list may be empty).
template <class P>
Field<P> names(std::vector<std::string> P::*m, std::string name, std::string description,
               Effect effect = Effect::Regenerate) {
  return bound(m, std::move(name), ParamType::Names, std::move(description), effect, 0, 0, read_names,
               [](const std::vector<std::string>& v) { return v; });
}

template <class P>
Field<P> color(Rgb P::*m, std::string name, std::string description, Effect effect = Effect::Recolour) {
  return bound(m, std::move(name), ParamType::Color, std::move(description), effect, 0, 0, read_color, write_color);
}

// Control points [[x, y], …], x strictly increasing, each coordinate in [min, max].
template <class P>
Field<P> curve(std::vector<CurvePoint> P::*m, std::string name, double min, double max, std::string description,
               Effect effect = Effect::Regenerate) {
  return bound(
      m, std::move(name), ParamType::Curve, std::move(description), effect, min, max,
      [min, max](const json& v, const std::string& path) { return read_curve(v, path, min, max); },
      [](const std::vector<CurvePoint>& points) {
        json a = json::array();
        for (auto& c : points) a.push_back(json::array({c.x, c.y}));
        return a;
      });
}

// Colour levels [{"at": 0.4, "color": "#rrggbb", "name": "sand"}, …], `at` non-decreasing in [min, max].
template <class P>
Field<P> levels(std::vector<Level> P::*m, std::string name, double min, double max, std::string description,
                Effect effect = Effect::Recolour) {
  return bound(
      m, std::move(name), ParamType::Levels, std::move(description), effect, min, max,
      [min, max](const json& v, const std::string& path) { return read_levels(v, path, min, max); }, write_levels);
}

// A list of integers, each in [min, max] (may be empty), e.g. [0, 0, 2, 3].
template <class P>
Field<P> int_list(std::vector<int> P::*m, std::string name, int min, int max, std::string description,
                  Effect effect = Effect::Regenerate) {
  return bound(
      m, std::move(name), ParamType::IntList, std::move(description), effect, min, max,
      [min, max](const json& v, const std::string& path) {
        if (!v.is_array()) throw Error(path, "expected a list of integers, got " + describe(v));
        std::vector<int> out;
        for (std::size_t k = 0; k < v.size(); ++k) out.push_back(int(read_int(v[k], path + "[" + std::to_string(k) + "]", min, max)));
        return out;
      },
      [](const std::vector<int>& v) { return v; });
}

// A parsed table: the fields of P plus helpers to read/write a whole object.
template <class P>
struct Table {
  std::vector<Field<P>> fields;

  std::vector<ParamInfo> infos() const {
    std::vector<ParamInfo> out;
    P defaults{};
    for (auto& f : fields) {
      ParamInfo i = f.info;
      i.default_value = f.write(defaults);
      out.push_back(std::move(i));
    }
    return out;
  }
  // Reads fields present in `obj` (a JSON object) into a default P. Keys in `ignore` are skipped;
  // any other unknown key is an error naming the nearest known field.
  P read(const json& obj, const std::string& path, const std::vector<std::string>& ignore = {}) const {
    P p{};
    if (!obj.is_object()) throw Error(path, "expected an object, got " + describe(obj));
    std::vector<std::string> names;
    for (auto& f : fields) names.push_back(f.info.name);
    for (auto it = obj.begin(); it != obj.end(); ++it) {
      const std::string& k = it.key();
      bool ign = false;
      for (auto& s : ignore) ign = ign || s == k;
      if (ign) continue;
      const Field<P>* hit = nullptr;
      for (auto& f : fields)
        if (f.info.name == k) hit = &f;
      const std::string fpath = path.empty() ? k : path + "." + k;
      if (!hit) {
        std::string near = nearest_name(k, names);
        throw Error(fpath, "unknown parameter" + (near.empty() ? std::string() : " (did you mean '" + near + "'?)"));
      }
      hit->read(p, it.value(), fpath);
    }
    return p;
  }
  json write(const P& p) const {
    json o = json::object();
    for (auto& f : fields) o[f.info.name] = f.write(p);
    return o;
  }
};

// A list of records [{…}, …] with min_count..max_count entries, each read by `table` into a default
// R (keys left out keep R's defaults; errors name `path[k].field`). The list's default is P's.
template <class P, class R>
Field<P> records(std::vector<R> P::*m, std::string name, Table<R> table, std::size_t min_count, std::size_t max_count,
                 std::string description, Effect effect = Effect::Regenerate) {
  Field<P> f = field_info<P>(std::move(name), ParamType::List, std::move(description), effect, double(min_count), double(max_count));
  f.info.fields = table.infos();
  auto shared = std::make_shared<const Table<R>>(std::move(table));
  f.read = [m, shared, min_count, max_count](P& p, const json& v, const std::string& path) {
    if (!v.is_array() || v.size() < min_count || v.size() > max_count)
      throw Error(path, "expected a list of " + std::to_string(min_count) + ".." + std::to_string(max_count) +
                            " objects, got " + describe(v));
    std::vector<R> out;
    for (std::size_t k = 0; k < v.size(); ++k) out.push_back(shared->read(v[k], path + "[" + std::to_string(k) + "]"));
    p.*m = std::move(out);
  };
  f.write = [m, shared](const P& p) {
    json a = json::array();
    for (auto& r : p.*m) a.push_back(shared->write(r));
    return a;
  };
  return f;
}

// Shared sub-tables: the fields of a table of S (e.g. the noise fields, the sea colours), bound to
// member `m` of P and appended flat to `out` (same keys, same paths, e.g. `stages[2].octaves`).
// Several stages declare the same thing once this way; their defaults are P's (the S member's
// initialiser), so two stages may share the fields but not their default values.
template <class P, class S>
void embed(std::vector<Field<P>>& out, S P::*m, const Table<S>& sub) {
  for (auto& sf : sub.fields) {
    Field<P> f;
    f.info = sf.info;
    f.read = [m, r = sf.read](P& p, const json& v, const std::string& path) { r(p.*m, v, path); };
    f.write = [m, w = sf.write](const P& p) { return w(p.*m); };
    out.push_back(std::move(f));
  }
}

}  // namespace relief
