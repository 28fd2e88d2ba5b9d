#include "relief/params.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace relief {

const char* to_string(ParamType t) {
  switch (t) {
    case ParamType::Int: return "int";
    case ParamType::Float: return "float";
    case ParamType::Bool: return "bool";
    case ParamType::Choice: return "choice";
    case ParamType::Color: return "color";
    case ParamType::Curve: return "curve";
    case ParamType::Levels: return "levels";
    case ParamType::Text: return "text";
    case ParamType::IntList: return "int_list";
    case ParamType::Names: return "names";
    case ParamType::List: return "list";
  }
  return "?";
}

json ParamInfo::to_json() const {
  json o;
  o["name"] = name;
  o["type"] = to_string(type);
  o["default"] = default_value;
  if (type == ParamType::Int || type == ParamType::Float || type == ParamType::Curve || type == ParamType::Levels ||
      type == ParamType::IntList || type == ParamType::List) {
    o["min"] = min;
    o["max"] = max;
    if (!values.empty()) o["values"] = values;
  }
  if (!unit.empty()) o["unit"] = unit;
  o["description"] = description;
  if (!choices.empty()) o["choices"] = choices;
  o["effect"] = effect == Effect::Regenerate ? "regenerate" : "recolour";
  if (!fields.empty()) {
    json fs = json::array();
    for (auto& f : fields) fs.push_back(f.to_json());
    o["fields"] = fs;
  }
  return o;
}

namespace {

// Length of the well-formed UTF-8 sequence at t[i] (RFC 3629: no overlongs, no surrogates, at
// most U+10FFFF), or 0 when the byte there does not start one.
std::size_t utf8_length(std::string_view t, std::size_t i) {
  const auto c = static_cast<unsigned char>(t[i]);
  if (c < 0x80) return 1;
  const std::size_t len = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
  if (len == 0 || i + len > t.size()) return 0;
  const auto c1 = static_cast<unsigned char>(t[i + 1]);
  const unsigned char lo = c == 0xE0 ? 0xA0 : c == 0xF0 ? 0x90 : 0x80;
  const unsigned char hi = c == 0xED ? 0x9F : c == 0xF4 ? 0x8F : 0xBF;
  if (c1 < lo || c1 > hi) return 0;
  for (std::size_t k = 2; k < len; ++k)
    if ((static_cast<unsigned char>(t[i + k]) & 0xC0) != 0x80) return 0;
  return len;
}

void append_escape(std::string& out, unsigned char c) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "\\u%04x", unsigned(c));
  out += buf;
}

}  // namespace

bool is_utf8(std::string_view t) {
  for (std::size_t i = 0; i < t.size();) {
    const std::size_t len = utf8_length(t, i);
    if (len == 0) return false;
    i += len;
  }
  return true;
}

std::string printable_text(std::string_view t) {
  bool plain = true;  // printable ASCII and '\n' need nothing
  for (unsigned char c : t) plain = plain && ((c >= 0x20 && c < 0x7f) || c == '\n');
  if (plain) return std::string(t);
  std::string out;
  out.reserve(t.size() + 8);
  for (std::size_t i = 0; i < t.size();) {
    const auto c = static_cast<unsigned char>(t[i]);
    const std::size_t len = utf8_length(t, i);
    if (len == 0) out += "\xEF\xBF\xBD", ++i;
    else if ((c < 0x20 && c != '\n') || c == 0x7f) append_escape(out, c), ++i;
    else out.append(t.substr(i, len)), i += len;
  }
  return out;
}

std::string quote(std::string_view text, std::size_t max_bytes) {
  std::string q = "\"";
  std::size_t i = 0;
  for (; i < text.size() && q.size() <= max_bytes; ) {
    const auto c = static_cast<unsigned char>(text[i]);
    const std::size_t len = utf8_length(text, i);
    if (len == 0) q += "\xEF\xBF\xBD", ++i;
    else if (c == '"' || c == '\\') q.push_back('\\'), q.push_back(char(c)), ++i;
    else if (c == '\n') q += "\\n", ++i;
    else if (c == '\t') q += "\\t", ++i;
    else if (c < 0x20 || c == 0x7f) append_escape(q, c), ++i;
    else q.append(text.substr(i, len)), i += len;
  }
  if (i < text.size()) q += "...";
  q.push_back('"');
  return q;
}

namespace {

// Compact JSON-like rendering, stopping once `out` passes `limit` bytes or `depth` levels.
void render(const json& v, std::string& out, std::size_t limit, int depth) {
  if (out.size() > limit) return;
  if (v.is_string()) {
    out += quote(v.get_ref<const std::string&>(), limit + 4 - std::min(limit, out.size()));
  } else if (v.is_array() || v.is_object()) {
    const bool arr = v.is_array();
    if (depth <= 0) {
      out += arr ? "[...]" : "{...}";
      return;
    }
    out.push_back(arr ? '[' : '{');
    bool first = true;
    for (auto it = v.begin(); it != v.end() && out.size() <= limit; ++it) {
      if (!first) out.push_back(',');
      first = false;
      if (!arr) {
        out += quote(it.key(), limit + 4 - std::min(limit, out.size()));
        out.push_back(':');
      }
      render(it.value(), out, limit, depth - 1);
    }
    out.push_back(arr ? ']' : '}');
  } else {
    out += v.dump();  // a number, a boolean or null: short and always valid
  }
}

}  // namespace

std::string describe(const json& v) {
  std::string s;
  render(v, s, 64, 8);
  if (s.size() > 60) {
    std::size_t k = 57;
    while (k > 0 && (static_cast<unsigned char>(s[k]) & 0xC0) == 0x80) --k;
    s.resize(k);
    s.append("...");
  }
  const char* kind = v.is_null() ? "null" : v.is_boolean() ? "a boolean" : v.is_number() ? nullptr
                     : v.is_string() ? "a string" : v.is_array() ? "an array" : "an object";
  if (!kind || v.is_string()) return s;
  if (v.is_null()) return "null";
  return std::string(kind) + " " + s;
}

void check_json_depth(std::string_view text, const std::string& origin, const std::string& path) {
  // The nesting depth, counted before parsing: nlohmann's parser is iterative, but copying,
  // comparing, dumping and destroying a document recurse once per level.
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth)
        throw Error(path, origin + " nests arrays and objects deeper than " + std::to_string(kMaxJsonDepth) +
                              " levels (at byte " + std::to_string(i) + ")");
    } else if (c == ']' || c == '}') {
      depth = std::max(0, depth - 1);
    }
  }
}

json parse_json(std::string_view text, const std::string& origin, const std::string& path) {
  check_json_depth(text, origin, path);
  try {
    return json::parse(text.begin(), text.end());
  } catch (const json::exception& e) {
    throw Error(path, origin + " is not valid JSON: " + e.what());
  }
}

// The shortest form that reads back as x (1.0000001 stays 1.0000001, not "1").
static std::string num(double x) {
  char buf[64];
  if (x == std::floor(x) && std::fabs(x) < 1e17) {
    std::snprintf(buf, sizeof buf, "%.0f", x);
    return buf;
  }
  for (int p = 6; p <= 17; ++p) {
    std::snprintf(buf, sizeof buf, "%.*g", p, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  return buf;
}

std::int64_t read_int(const json& v, const std::string& path, double min, double max) {
  const std::string expect = "expected an integer in " + num(min) + ".." + num(max);
  if (v.is_number_integer() || v.is_number_unsigned()) {
    double d = v.is_number_unsigned() ? double(v.get<std::uint64_t>()) : double(v.get<std::int64_t>());
    if (d < min || d > max) throw Error(path, expect + ", got " + v.dump());
    return v.is_number_unsigned() ? std::int64_t(v.get<std::uint64_t>()) : v.get<std::int64_t>();
  }
  if (v.is_number_float()) {
    double d = v.get<double>();
    if (std::isfinite(d) && d == std::floor(d) && d >= min && d <= max) return std::int64_t(d);
  }
  throw Error(path, expect + ", got " + describe(v));
}

double read_float(const json& v, const std::string& path, double min, double max) {
  const std::string expect = "expected a number in " + num(min) + ".." + num(max);
  if (!v.is_number()) throw Error(path, expect + ", got " + describe(v));
  double d = v.get<double>();
  if (!std::isfinite(d)) throw Error(path, expect + ", got a non-finite value");
  if (d < min || d > max) throw Error(path, expect + ", got " + num(d));
  return d;
}

bool read_bool(const json& v, const std::string& path) {
  if (!v.is_boolean()) throw Error(path, "expected true or false, got " + describe(v));
  return v.get<bool>();
}

std::string read_choice(const json& v, const std::string& path, const std::vector<std::string>& choices) {
  std::string list;
  for (auto& c : choices) list += (list.empty() ? "" : ", ") + c;
  if (!v.is_string()) throw Error(path, "expected one of " + list + ", got " + describe(v));
  std::string s = v.get<std::string>();
  if (std::find(choices.begin(), choices.end(), s) == choices.end()) {
    std::string near = nearest_name(s, choices);
    throw Error(path, "expected one of " + list + ", got " + quote(s) +
                          (near.empty() ? "" : " (did you mean '" + near + "'?)"));
  }
  return s;
}

static int hexval(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

Rgb read_color(const json& v, const std::string& path) {
  const std::string expect = "expected a colour \"#rrggbb\" or [r, g, b] with 0..255 each";
  if (v.is_string()) {
    std::string s = v.get<std::string>();
    if (s.size() == 7 && s[0] == '#') {
      int c[6];
      bool ok = true;
      for (int k = 0; k < 6; ++k) ok = ok && (c[k] = hexval(s[k + 1])) >= 0;
      if (ok) return Rgb{(c[0] * 16 + c[1]) / 255.0f, (c[2] * 16 + c[3]) / 255.0f, (c[4] * 16 + c[5]) / 255.0f};
    }
    throw Error(path, expect + ", got " + describe(v));
  }
  if (v.is_array() && v.size() == 3) {
    float c[3];
    for (int k = 0; k < 3; ++k) c[k] = float(read_float(v[k], path + "[" + std::to_string(k) + "]", 0, 255) / 255.0);
    return Rgb{c[0], c[1], c[2]};
  }
  throw Error(path, expect + ", got " + describe(v));
}

json write_color(const Rgb& c) {
  auto b = [](float x) { return int(std::lround(std::clamp(x, 0.0f, 1.0f) * 255.0f)); };
  // "#rrggbb" when that is exact (as read_color reads it back); otherwise [r, g, b] in 0..255 with
  // every bit kept (x·255 is exact in a double, and read_color's /255 gives x back), so that a
  // resolved recipe (--save-recipe) reproduces colours such as 0.25 exactly.
  auto hex_exact = [&](float x) { return float(b(x)) / 255.0f == x; };
  if (!hex_exact(c.r) || !hex_exact(c.g) || !hex_exact(c.b))
    return json::array({double(c.r) * 255.0, double(c.g) * 255.0, double(c.b) * 255.0});
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", b(c.r), b(c.g), b(c.b));
  return std::string(buf);
}

std::vector<CurvePoint> read_curve(const json& v, const std::string& path, double min, double max) {
  if (!v.is_array() || v.size() < 2)
    throw Error(path, "expected at least 2 control points [[x, y], …], got " + describe(v));
  std::vector<CurvePoint> out;
  for (std::size_t k = 0; k < v.size(); ++k) {
    const std::string p = path + "[" + std::to_string(k) + "]";
    if (!v[k].is_array() || v[k].size() != 2) throw Error(p, "expected a point [x, y], got " + describe(v[k]));
    CurvePoint c{read_float(v[k][0], p + "[0]", min, max), read_float(v[k][1], p + "[1]", min, max)};
    if (!out.empty() && !(c.x > out.back().x))
      throw Error(p + "[0]", "expected x greater than the previous point's " + num(out.back().x) + ", got " + num(c.x));
    out.push_back(c);
  }
  return out;
}

std::vector<Level> read_levels(const json& v, const std::string& path, double min, double max) {
  if (!v.is_array() || v.empty())
    throw Error(path, "expected a non-empty list of levels [{\"at\": x, \"color\": \"#rrggbb\"}, …], got " + describe(v));
  std::vector<Level> out;
  for (std::size_t k = 0; k < v.size(); ++k) {
    const std::string p = path + "[" + std::to_string(k) + "]";
    const json& e = v[k];
    if (!e.is_object()) throw Error(p, "expected an object {\"at\": x, \"color\": \"#rrggbb\"}, got " + describe(e));
    Level l;
    for (auto it = e.begin(); it != e.end(); ++it) {
      if (it.key() == "at") l.at = read_float(it.value(), p + ".at", min, max);
      else if (it.key() == "color") l.color = read_color(it.value(), p + ".color");
      else if (it.key() == "name") {
        if (!it.value().is_string()) throw Error(p + ".name", "expected a string, got " + describe(it.value()));
        l.name = it.value().get<std::string>();
      } else if (it.key() == "texture") {
        if (!it.value().is_string()) throw Error(p + ".texture", "expected a PNG file name, got " + describe(it.value()));
        l.texture = it.value().get<std::string>();
      } else if (it.key() == "tile_m") {
        l.tile_m = read_float(it.value(), p + ".tile_m", 0.01, 1e6);
      } else {
        throw Error(p + "." + it.key(), "unknown key (expected at, color, name, texture, tile_m)");
      }
    }
    if (!e.contains("at")) throw Error(p + ".at", "missing");
    if (!e.contains("color")) throw Error(p + ".color", "missing");
    if (!out.empty() && l.at < out.back().at)
      throw Error(p + ".at", "expected levels in increasing order (≥ " + num(out.back().at) + "), got " + num(l.at));
    out.push_back(l);
  }
  return out;
}

json write_levels(const std::vector<Level>& levels) {
  json a = json::array();
  for (auto& l : levels) {
    json o;
    o["at"] = l.at;
    o["color"] = write_color(l.color);
    if (!l.name.empty()) o["name"] = l.name;
    if (!l.texture.empty()) {
      o["texture"] = l.texture;
      o["tile_m"] = l.tile_m;
    }
    a.push_back(o);
  }
  return a;
}

std::vector<std::string> read_names(const json& v, const std::string& path) {
  if (!v.is_array()) throw Error(path, "expected a list of names [\"a\", …], got " + describe(v));
  std::vector<std::string> out;
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!v[k].is_string() || v[k].get<std::string>().empty())
      throw Error(path + "[" + std::to_string(k) + "]", "expected a non-empty name, got " + describe(v[k]));
    out.push_back(v[k].get<std::string>());
  }
  return out;
}

static std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string nearest_name(const std::string& given, const std::vector<std::string>& names) {
  std::string best;
  std::size_t bestd = std::string::npos;
  for (auto& n : names) {
    std::size_t d = edit_distance(given, n);
    if (n.find(given) != std::string::npos || given.find(n) != std::string::npos) d = std::min<std::size_t>(d, 1);
    if (d < bestd) bestd = d, best = n;
  }
  if (best.empty() || bestd > std::max<std::size_t>(2, given.size() / 2)) return "";
  return best;
}

}  // namespace relief
