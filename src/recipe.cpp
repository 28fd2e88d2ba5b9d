#include "relief/recipe.hpp"
#include "relief/generate.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "relief/output.hpp"

namespace relief {
namespace detail {
const std::vector<std::pair<std::string_view, std::string_view>>& builtin_preset_texts();
}

namespace {

int read_size(const json& v, const std::string& path) { return int(read_int(v, path, kMinSize, kMaxSize)); }

// `size`: N (square) or [nx, nz]; written as [nx, nz].
Field<World> size_field() {
  Field<World> f;
  f.info.name = "size";
  f.info.type = ParamType::Int;
  f.info.min = kMinSize;
  f.info.max = kMaxSize;
  f.info.description = "Samples per axis, corners included: N or [nx, nz] (2^n+1 suits engines)";
  f.read = [](World& w, const json& s, const std::string& path) {
    if (s.is_array()) {
      if (s.size() != 2) throw Error(path, "expected N or [nx, nz], got " + describe(s));
      w.nx = read_size(s[0], path + "[0]");
      w.nz = read_size(s[1], path + "[1]");
    } else {
      w.nx = w.nz = read_size(s, path);
    }
  };
  f.write = [](const World& w) { return json::array({w.nx, w.nz}); };
  return f;
}

Table<World> make_world_table() {
  using W = World;
  return {{
      size_field(),
      param(&W::width_m, "width_m", 1, 1e7, "m", "World extent along x; depth follows the sample aspect"),
      param(&W::height_m, "height_m", 0.01, 1e5, "m", "Metres between elevation 0 and elevation 1"),
      param(&W::sea_level, "sea_level", 0, 1, "", "Normalised elevation of the sea surface"),
  }};
}

}  // namespace

Frame World::frame() const {
  Frame f;
  f.nx = nx;
  f.nz = nz;
  f.world_width_m = width_m;
  f.spacing_m = width_m / (nx - 1);
  f.world_depth_m = f.spacing_m * (nz - 1);
  f.height_m = height_m;
  f.sea_level = sea_level;
  return f;
}

const Table<World>& world_table() {
  static const Table<World> t = make_world_table();
  return t;
}

std::vector<ParamInfo> world_params() { return world_table().infos(); }

ExportSettings parse_export_settings(const json& block, const std::string& path) {
  if (!block.is_object()) throw Error(path, "expected an object of writer options, got " + describe(block));
  ExportSettings e;
  if (block.contains("formats")) {
    const json& f = block["formats"];
    const std::string fp = path + ".formats";
    if (!f.is_string()) throw Error(fp, "expected \"default\", \"all\" or comma-separated format names, got " + describe(f));
    const std::string text = f.get<std::string>();
    select_writers(text, ExportOptions{}, fp);  // validates the names (the one parser of format lists)
    if (text != "default") e.formats = text;  // "all" stays "all"
  }
  e.options = export_options_table().read(block, path, {"formats"});
  validate_export_options(e.options, [&](const std::string& n) { return path + "." + n; });
  return e;
}

json export_settings_json(const ExportSettings& e) {
  json o = export_options_table().write(e.options);
  o["formats"] = e.formats.empty() ? "default" : e.formats;
  return o;
}

json Recipe::to_json() const {
  json o;
  o["name"] = name;
  if (!description.empty()) o["description"] = description;
  if (seed) o["seed"] = *seed;
  o["world"] = world_table().write(world);
  json st = json::array();
  for (auto& s : stages) {
    json e;
    e["stage"] = s.def->name;
    if (!s.label.empty()) e["label"] = s.label;
    const json params = s.stage->params();
    for (auto it = params.begin(); it != params.end(); ++it) e[it.key()] = it.value();
    st.push_back(e);
  }
  o["stages"] = st;
  if (export_settings) o["export"] = export_settings_json(*export_settings);
  return o;
}

Recipe parse_recipe(const json& doc) {
  if (!doc.is_object()) throw Error("", "a recipe must be a JSON object, got " + describe(doc));
  Recipe r;
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    const std::string& k = it.key();
    const json& v = it.value();
    if (k == "name" || k == "description") {
      if (!v.is_string()) throw Error(k, "expected a string, got " + describe(v));
      if (!is_utf8(v.get_ref<const std::string&>())) throw Error(k, "expected UTF-8 text, got " + describe(v));
      (k == "name" ? r.name : r.description) = v.get<std::string>();
    } else if (k == "seed") {
      r.seed = std::uint64_t(read_int(v, "seed", 0, double(kMaxSeed)));
    } else if (k == "world") {
      r.world = world_table().read(v, "world");
    } else if (k == "stages") {
      if (!v.is_array()) throw Error("stages", "expected a list of stages, got " + describe(v));
      for (std::size_t i = 0; i < v.size(); ++i) {
        const std::string path = "stages[" + std::to_string(i) + "]";
        const json& e = v[i];
        if (!e.is_object()) throw Error(path, "expected an object {\"stage\": NAME, …}, got " + describe(e));
        if (!e.contains("stage") || !e["stage"].is_string())
          throw Error(path + ".stage", "expected a stage name, got " + (e.contains("stage") ? describe(e["stage"]) : std::string("nothing")));
        const std::string name = e["stage"].get<std::string>();
        const StageDef* def = find_stage(name);
        if (!def) {
          std::vector<std::string> names;
          for (auto& d : stage_registry()) names.push_back(d.name);
          std::string near = nearest_name(name, names);
          throw Error(path + ".stage", "unknown stage " + quote(name) +
                                           (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                                           "; `relief explain` lists the stages");
        }
        RecipeStage rs;
        rs.def = def;
        if (e.contains("label")) {
          if (!e["label"].is_string() || !is_utf8(e["label"].get_ref<const std::string&>()))
            throw Error(path + ".label", "expected a string of UTF-8 text, got " + describe(e["label"]));
          rs.label = e["label"].get<std::string>();
        }
        rs.stage = def->parse(e, path);
        r.stages.push_back(std::move(rs));
      }
    } else if (k == "export") {
      r.export_settings = parse_export_settings(v, "export");
    } else {
      std::string near = nearest_name(k, {"name", "description", "seed", "world", "stages", "export"});
      throw Error(k, "unknown recipe key" + (near.empty() ? std::string() : " (did you mean '" + near + "'?)"));
    }
  }
  return r;
}

Recipe parse_recipe_text(const std::string& text, const std::string& origin) {
  return parse_recipe(parse_json(text, origin));
}

// ---- overrides ------------------------------------------------------------------------------

void apply_override(json& doc, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw Error("--set", "expected PATH=VALUE (e.g. stages[1].octaves=8), got " + quote(assignment));
  const std::string path = assignment.substr(0, eq);
  const std::string text = assignment.substr(eq + 1);
  // Bounded: a path of 100,000 ".a" would build a document too deep to copy or print.
  if (path.size() > 4096 || std::count_if(path.begin(), path.end(), [](char c) { return c == '.' || c == '['; }) > kMaxJsonDepth)
    throw Error("--set", "expected a path of at most " + std::to_string(kMaxJsonDepth) + " levels and 4096 bytes, got " + quote(path));
  check_json_depth(text, "the value", path);
  json value;
  try {
    value = json::parse(text);
  } catch (const json::parse_error&) {
    // Not JSON: the text itself, which must be text (it ends up in files and messages).
    if (!is_utf8(text)) throw Error(path, "expected UTF-8 text, got " + quote(text));
    value = text;
  } catch (const json::exception&) {  // e.g. 1e999: a number JSON cannot hold
    throw Error(path, "expected a finite value, got " + quote(text));
  }
  // A path into a stage parameter the recipe leaves at its default (`stages[2].types[1].octaves`
  // where the recipe has no `types`) first copies that parameter's default into the stage object.
  if (path.rfind("stages[", 0) == 0 && doc.is_object() && doc.contains("stages") && doc["stages"].is_array()) {
    const auto close = path.find(']');
    const std::string idx = close == std::string::npos ? "" : path.substr(7, close - 7);
    if (!idx.empty() && idx.size() < 6 && idx.find_first_not_of("0123456789") == std::string::npos &&
        close + 1 < path.size() && path[close + 1] == '.') {
      const std::size_t i = std::stoul(idx);
      const std::string rest = path.substr(close + 2);
      const std::string key = rest.substr(0, rest.find_first_of(".["));
      json& st = doc["stages"];
      if (i < st.size() && st[i].is_object() && key != rest && !st[i].contains(key) && st[i].contains("stage") &&
          st[i]["stage"].is_string()) {
        if (const StageDef* def = find_stage(st[i]["stage"].get<std::string>())) {
          try {
            const json params = def->parse(st[i], "stages[" + idx + "]")->params();
            if (params.contains(key)) st[i][key] = params[key];
          } catch (const Error&) {
            // The stage object is invalid as it stands: the walk below reports the path.
          }
        }
      }
    }
  }
  // Walk a.b[2].c
  json* cur = &doc;
  std::string walked;
  std::size_t p = 0;
  while (p < path.size()) {
    if (path[p] == '[') {
      auto close = path.find(']', p);
      if (close == std::string::npos) throw Error(path, "malformed path: missing ']'");
      const std::string idx = path.substr(p + 1, close - p - 1);
      if (idx.empty() || idx.find_first_not_of("0123456789") != std::string::npos)
        throw Error(path, "malformed path: index " + quote(idx) + " is not a number");
      // Any index of more than 9 digits is out of range (and would overflow std::stoul).
      const std::size_t i = idx.size() > 9 ? std::size_t(-1) : std::stoul(idx);
      walked += "[" + idx + "]";
      if (!cur->is_array() || i >= cur->size())
        throw Error(walked, cur->is_array() ? "index out of range (there are " + std::to_string(cur->size()) + ")"
                                            : "not a list");
      p = close + 1;
      if (p < path.size() && path[p] == '.') ++p;
      if (p >= path.size()) {
        (*cur)[i] = value;
        return;
      }
      cur = &(*cur)[i];
    } else {
      auto end = path.find_first_of(".[", p);
      const std::string key = path.substr(p, end == std::string::npos ? std::string::npos : end - p);
      if (key.empty()) throw Error(path, "malformed path");
      walked += (walked.empty() ? "" : ".") + key;
      if (cur->is_null()) *cur = json::object();
      if (!cur->is_object()) throw Error(walked, "cannot set a field inside " + describe(*cur));
      if (end == std::string::npos) {
        (*cur)[key] = value;
        return;
      }
      cur = &(*cur)[key];
      p = end;
      if (path[p] == '.') ++p;
    }
  }
  throw Error(path, "malformed path");
}

// ---- presets --------------------------------------------------------------------------------

namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw Error("preset", "cannot read '" + p.string() + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// name → (origin, text); user presets replace built-ins of the same name; earlier dirs win.
std::vector<std::pair<std::string, std::pair<std::string, std::string>>> all_presets(const std::vector<std::string>& user_dirs,
                                                                               bool read_user_text) {
  std::vector<std::pair<std::string, std::pair<std::string, std::string>>> out;
  auto put = [&](const std::string& name, std::string origin, std::string text) {
    for (auto& e : out)
      if (e.first == name) return;
    out.push_back({name, {std::move(origin), std::move(text)}});
  };
  std::error_code ec;
  for (const std::string& dir : user_dirs) {
    const std::filesystem::path d(dir);
    if (!std::filesystem::is_directory(d, ec)) continue;
    std::vector<std::filesystem::path> files;
    for (auto& e : std::filesystem::directory_iterator(d, ec))
      if (e.path().extension() == ".json") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (auto& f : files) {
      std::string text;
      if (read_user_text) {
        try {
          text = read_text(f);
        } catch (const Error&) {
          continue;
        }
      }
      put(f.stem().string(), f.string(), text);
    }
  }
  for (auto& [n, t] : detail::builtin_preset_texts()) put(std::string(n), "built-in", std::string(t));
  std::sort(out.begin(), out.end(), [](auto& a, auto& b) { return a.first < b.first; });
  return out;
}

}  // namespace

std::vector<std::string> user_preset_dirs(const char* relief_presets, const char* xdg_config_home, const char* home) {
  std::vector<std::string> dirs;
  if (relief_presets) {
    const std::string_view s = relief_presets;
    std::size_t start = 0;
    while (start <= s.size()) {
      const auto end = s.find(':', start);
      const std::string_view d = s.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start);
      if (!d.empty()) dirs.emplace_back(d);
      if (end == std::string_view::npos) break;
      start = end + 1;
    }
  }
  if (xdg_config_home && *xdg_config_home)
    dirs.push_back((std::filesystem::path(xdg_config_home) / "relief" / "presets").string());
  else if (home && *home)
    dirs.push_back((std::filesystem::path(home) / ".config" / "relief" / "presets").string());
  return dirs;
}

std::vector<PresetInfo> list_presets(const std::vector<std::string>& user_dirs) {
  std::vector<PresetInfo> out;
  for (auto& [name, ot] : all_presets(user_dirs, true)) {
    PresetInfo pi{name, "", ot.first};
    try {
      json doc = parse_json(ot.second, "preset");
      if (doc.is_object() && doc.contains("description") && doc["description"].is_string())
        pi.description = doc["description"].get<std::string>();
    } catch (const Error&) {
      pi.description = "(not valid JSON)";
    }
    out.push_back(pi);
  }
  return out;
}

json load_preset(const std::string& name, const std::vector<std::string>& user_dirs) {
  auto all = all_presets(user_dirs, true);
  for (auto& [n, ot] : all) {
    if (n != name) continue;
    return parse_json(ot.second, "'" + ot.first + "'", "preset");
  }
  std::vector<std::string> names;
  for (auto& e : all) names.push_back(e.first);
  std::string near = nearest_name(name, names);
  std::string list;
  for (auto& n : names) list += (list.empty() ? "" : ", ") + n;
  throw Error("preset", "unknown preset " + quote(name) + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                            "; available: " + list);
}

// ---- recipe files -------------------------------------------------------------------------------

namespace {
void resolve_file(json& value, const std::filesystem::path& base) {
  const std::string file = value.get<std::string>();
  if (!file.empty() && std::filesystem::path(file).is_relative()) value = (base / file).lexically_normal().string();
}

// The file names a recipe holds: every string member named "texture" below `v` (colour levels,
// biome types and their colours, climate table entries), and the "path" of an image stage.
void resolve_files(json& v, const std::filesystem::path& base) {
  if (v.is_array()) {
    for (json& e : v) resolve_files(e, base);
  } else if (v.is_object()) {
    const auto stage = v.find("stage");
    const bool image = stage != v.end() && stage->is_string() && stage->get<std::string>() == "image";
    for (auto it = v.begin(); it != v.end(); ++it) {
      if ((it.key() == "texture" || (image && it.key() == "path")) && it.value().is_string())
        resolve_file(it.value(), base);
      else
        resolve_files(it.value(), base);
    }
  }
}
}  // namespace

void resolve_recipe_files(json& doc, const std::string& base_dir) {
  if (!doc.is_object() || !doc.contains("stages")) return;
  std::error_code ec;
  std::filesystem::path base = std::filesystem::absolute(base_dir.empty() ? "." : base_dir, ec);
  if (ec) base = base_dir;
  resolve_files(doc["stages"], base);
}

json read_recipe_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("recipe", "cannot read '" + path + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  json doc = parse_json(ss.str(), "'" + path + "'", "recipe");
  resolve_recipe_files(doc, std::filesystem::path(path).parent_path().string());
  return doc;
}

}  // namespace relief
