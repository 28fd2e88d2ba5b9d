#include "studio_request.hpp"

#include "relief/generate.hpp"

#include <algorithm>
#include <cctype>

#include "relief/pipeline.hpp"

namespace relief::cli {

namespace {

json parse_body(std::string_view text, const std::vector<std::string>& allowed, const StudioSettings& s) {
  if (text.size() > s.max_body)
    throw ApiError{413, "", "request body too large: " + std::to_string(text.size()) + " bytes, limit " + std::to_string(s.max_body)};
  json body;
  try {
    body = parse_json(text, "request body");
  } catch (const Error& e) {
    throw ApiError{400, "", e.what()};
  }
  if (!body.is_object()) throw ApiError{400, "", "request body: expected a JSON object, got " + describe(body)};
  for (auto& [k, v] : body.items())
    if (std::find(allowed.begin(), allowed.end(), k) == allowed.end()) {
      std::string list;
      for (auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw ApiError{400, k, "unknown request field (expected " + list + ")"};
    }
  if (!body.contains("recipe")) throw ApiError{400, "recipe", "missing: the request needs a recipe object"};
  return body;
}

// Every field below `v` that names a file: the "path" of an {"stage": "image"} object and a
// non-empty string "texture". An image path "upload:NAME" of an upload in `uploads` is replaced by
// its in-memory path (recorded in r.uploads); "" is left to the stage (refused when it runs);
// anything else is refused, naming the field. Bounded by parse_body's depth limit.
void check_files(json& v, const std::string& at, const UploadPaths& uploads, StudioRequest& r) {
  if (v.is_array()) {
    for (std::size_t i = 0; i < v.size(); ++i) check_files(v[i], at + "[" + std::to_string(i) + "]", uploads, r);
  } else if (v.is_object()) {
    const auto stage = v.find("stage");
    const bool image = stage != v.end() && stage->is_string() && stage->get<std::string>() == "image";
    for (auto it = v.begin(); it != v.end(); ++it) {
      const std::string field = at + "." + it.key();
      if (image && it.key() == "path") {
        if (!it.value().is_string()) continue;  // parse_recipe names the wrong type
        const std::string path = it.value().get<std::string>();
        if (path.empty()) continue;
        if (!path.starts_with(kUploadPrefix))
          throw ApiError{400, field,
                         "the studio does not read files named by a request: upload the image (drop it on the image stage, "
                         "or use its file button) and use the \"upload:NAME\" path it gets, or run the recipe with `relief generate`"};
        const std::string name = path.substr(kUploadPrefix.size());
        const auto u = uploads.find(name);
        if (u == uploads.end()) {
          std::string list;
          for (auto& [n, p] : uploads) list += (list.empty() ? "" : ", ") + n;
          throw ApiError{400, field,
                         "no upload named " + quote(name) + " in this session (uploads are kept per page session; upload the file again)" +
                             (list.empty() ? std::string() : "; uploaded: " + list)};
        }
        r.uploads[u->second] = name;
        it.value() = u->second;
        continue;
      }
      if (it.key() == "texture" && it.value().is_string() && !it.value().get<std::string>().empty())
        throw ApiError{400, field,
                       "the studio does not read files named by a request (colour textures): use `relief generate` with the "
                       "recipe file"};
      check_files(it.value(), field, uploads, r);
    }
  }
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  if (from.empty()) return;
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
}

// Gives every image path of `v` that is an in-memory path of r back as `prefix` + NAME.
void client_paths(json& v, const StudioRequest& r, const std::string& prefix) {
  if (v.is_array()) {
    for (json& e : v) client_paths(e, r, prefix);
  } else if (v.is_object()) {
    for (auto it = v.begin(); it != v.end(); ++it) {
      if (it.key() == "path" && it.value().is_string()) {
        const auto u = r.uploads.find(it.value().get<std::string>());
        if (u != r.uploads.end()) it.value() = prefix + u->second;
      } else {
        client_paths(it.value(), r, prefix);
      }
    }
  }
}

}  // namespace

StudioRequest parse_studio_request(Endpoint e, std::string_view text, const StudioSettings& s, const UploadPaths& uploads) {
  static const std::vector<std::string> fields[] = {{"recipe"}, {"recipe", "layers"}, {"recipe"}, {"recipe", "format", "file"}, {"recipe"}};
  const int max_size = e == Endpoint::Generate || e == Endpoint::Steps ? s.max_preview : s.max_export;
  StudioRequest r;
  r.body = parse_body(text, fields[int(e)], s);
  // Counted before the recipe is parsed: parsing and validating tens of thousands of stages is
  // itself work the studio should not do for a request it will refuse.
  if (const json& rj = r.body["recipe"]; rj.is_object() && rj.contains("stages") && rj["stages"].is_array() &&
                                          rj["stages"].size() > std::size_t(s.max_stages))
    throw ApiError{400, "stages",
                   "the studio runs at most " + std::to_string(s.max_stages) + " stages per recipe (--max-stages), got " +
                       std::to_string(rj["stages"].size()) + " (use `relief generate` for longer recipes)"};
  // The server never opens a file a client names: an image stage's "path" must name an upload of
  // this session, and a colour's "texture" is refused, before parsing (which reads the image's header).
  if (json& rj = r.body["recipe"]; rj.is_object() && rj.contains("stages")) check_files(rj["stages"], "stages", uploads, r);
  try {
    r.recipe = parse_recipe(r.body["recipe"]);
  } catch (const Error& err) {
    // Recipe paths stay relative to the recipe (as on the command line and in the panel).
    if (err.path().empty()) throw ApiError{400, "recipe", client_text(r, err.message())};
    throw ApiError{400, err.path(), client_text(r, err.message())};
  }
  const World& w = r.recipe.world;
  if (w.nx > max_size || w.nz > max_size)
    throw ApiError{400, "world.size",
                   "the studio accepts at most " + std::to_string(max_size) + " samples per axis here, got " +
                       std::to_string(w.nx) + "x" + std::to_string(w.nz) +
                       (max_size == s.max_preview ? " (export larger sizes, or use `relief generate`)" : " (use `relief generate`)")};
  if (!r.recipe.seed) r.recipe.seed = random_seed();
  r.frame = r.recipe.world.frame();

  if (e == Endpoint::Generate && r.body.contains("layers")) {
    const json& l = r.body["layers"];
    if (!l.is_array()) throw ApiError{400, "layers", "expected a list of layer names, got " + describe(l)};
    // Known: the layers stages write under fixed names, and those a stage of this recipe names
    // (a noise stage's "layer"). A known layer this terrain lacks is simply not sent.
    std::vector<std::string> known = {"height", "albedo", "color", "shade", "slope", "slope_deg", "biome", "moisture",
                                      "temperature", "water", "flow", "offset", "volcano"};
    for (auto& st : r.recipe.stages) {
      const json p = st.stage->params();
      if (p.contains("layer") && p["layer"].is_string() &&
          std::find(known.begin(), known.end(), p["layer"].get<std::string>()) == known.end())
        known.push_back(p["layer"].get<std::string>());
    }
    for (std::size_t i = 0; i < l.size(); ++i) {
      const std::string path = "layers[" + std::to_string(i) + "]";
      if (!l[i].is_string()) throw ApiError{400, path, "expected a layer name, got " + describe(l[i])};
      const std::string name = l[i].get<std::string>();
      if (std::find(known.begin(), known.end(), name) == known.end()) {
        std::string list;
        for (auto& k : known) list += (list.empty() ? "" : ", ") + k;
        const std::string near = nearest_name(name, known);
        throw ApiError{400, path, "unknown layer " + quote(name) + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                                      "; known: " + list};
      }
      r.layers.push_back(name);
    }
    r.all_layers = false;
  }
  if (e == Endpoint::Export) {
    if (!r.body.contains("format") || !r.body["format"].is_string())
      throw ApiError{400, "format", "expected a format name, got " + (r.body.contains("format") ? describe(r.body["format"]) : "nothing")};
    const std::string fmt = r.body["format"].get<std::string>();
    r.writer = find_writer(fmt);
    if (!r.writer) {
      std::vector<std::string> names;
      std::string list;
      for (auto& wd : writer_registry()) names.push_back(wd.name), list += (list.empty() ? "" : ", ") + wd.name;
      const std::string near = nearest_name(fmt, names);
      throw ApiError{400, "format", "unknown format " + quote(fmt) + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                                        "; available: " + list};
    }
    if (r.body.contains("file")) {
      if (!r.body["file"].is_string()) throw ApiError{400, "file", "expected a file name, got " + describe(r.body["file"])};
      r.file = r.body["file"].get<std::string>();
    }
    // The one memory policy (relief/generate.hpp), for this format's writers and those it implies.
    try {
      const ExportOptions options = r.recipe.export_settings ? r.recipe.export_settings->options : ExportOptions{};
      check_memory(r.recipe, select_writers(fmt, options, "format").with_mesh());
    } catch (const ApiError&) {
      throw;
    } catch (const Error& e) {
      throw ApiError{400, e.path(), std::string(e.what()).substr(e.path().empty() ? 0 : e.path().size() + 2)};
    }
  }
  return r;
}

json client_recipe_json(const StudioRequest& r, bool saved) {
  json j = r.recipe.to_json();
  if (!r.uploads.empty() && j.contains("stages")) client_paths(j["stages"], r, saved ? "" : std::string(kUploadPrefix));
  return j;
}

std::string client_text(const StudioRequest& r, std::string text) {
  for (auto& [path, name] : r.uploads) replace_all(text, path, std::string(kUploadPrefix) + name);
  return text;
}

std::string upload_name(std::string_view name) {
  if (const auto slash = name.find_last_of("/\\"); slash != std::string_view::npos) name = name.substr(slash + 1);
  std::string out;
  for (char c : name.substr(0, 100)) out += std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_' ? c : '_';
  while (!out.empty() && out.front() == '.') out.erase(0, 1);
  if (out == "recipe.json") out = "upload-recipe.json";
  return out;
}

std::string content_disposition(std::string_view filename) {
  const std::string name = printable_text(filename.substr(0, 200));  // valid UTF-8; controls as \u00XX
  std::string ascii, encoded;
  for (std::size_t i = 0; i < name.size(); ++i) {
    const auto c = static_cast<unsigned char>(name[i]);
    const bool control = c == '\\' && name.compare(i, 2, "\\u") == 0;  // an escape printable_text wrote
    if (control) {
      ascii += '_', encoded += '_';
      i += 5;
      continue;
    }
    if (c < 0x20 || c == 0x7f) {  // '\n' (the one control printable_text keeps)
      ascii += '_', encoded += '_';
      continue;
    }
    const bool safe = std::isalnum(c) || c == '.' || c == '-' || c == '_';
    ascii += c < 0x80 && safe ? char(c) : '_';
    if (c < 0x80 && (safe || c == '!' || c == '#' || c == '$' || c == '&' || c == '+' || c == '^' || c == '`' || c == '|' || c == '~')) {
      encoded += char(c);
    } else if (c == '/' || c == '\\') {
      encoded += '_';
    } else {
      static const char* hex = "0123456789ABCDEF";
      encoded += '%';
      encoded += hex[c >> 4];
      encoded += hex[c & 15];
    }
  }
  if (ascii.empty()) ascii = encoded = "download";
  return "attachment; filename=\"" + ascii + "\"; filename*=UTF-8''" + encoded;
}

std::uint64_t work_budget_bytes(const StudioSettings& s) {
  if (s.work_mib) return std::uint64_t(s.work_mib) << 20;
  const std::uint64_t cap = 4ull << 30, phys = physical_memory_bytes();
  return phys ? std::min(cap, phys / 4) : cap;
}

bool valid_client_id(std::string_view s) {
  if (s.empty() || s.size() > 64) return false;
  return std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum((unsigned char)c) || c == '-' || c == '_'; });
}

}  // namespace relief::cli
