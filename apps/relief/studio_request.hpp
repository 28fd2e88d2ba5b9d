#pragma once
// The studio's request parsing, apart from the HTTP server so that tests and fuzz targets can
// drive it (fuzz/fuzz_studio_request.cpp). Everything a client sends is read here: the JSON body of
// POST /api/resolve, /api/generate, /api/steps and /api/export, and the X-Relief-Client header.
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "relief/error.hpp"
#include "relief/output.hpp"
#include "relief/recipe.hpp"
#include "studio.hpp"

namespace relief::cli {

// A refused request: an Error (field path and message) with the HTTP status to answer with.
class ApiError : public Error {
 public:
  ApiError(int status, std::string path, std::string message)
      : Error(path, message), status_(status), message_(printable_text(message)) {}
  int status() const noexcept { return status_; }
  const std::string& message() const noexcept { return message_; }  // without the path

 private:
  int status_;
  std::string message_;
};

enum class Endpoint { Resolve, Generate, Steps, Export, Save };

// The uploads a request may name (its client's: uploads are kept per session): an image stage's
// "path": "upload:NAME" names the upload NAME, which the studio holds in memory under a path of the
// library's in-memory rasters (relief/image.hpp, register_memory_raster). NAME → that path.
using UploadPaths = std::map<std::string, std::string>;
inline constexpr std::string_view kUploadPrefix = "upload:";

struct StudioRequest {
  json body;
  Recipe recipe;  // validated; its seed is set (drawn at random when the body has none)
  Frame frame;    // the recipe's whole world
  // generate: the layers asked for (all when all_layers)
  std::vector<std::string> layers;
  bool all_layers = true;
  // export: the writer and, optionally, the one file of it wanted
  const WriterDef* writer = nullptr;
  std::string file;
  // The uploads the recipe names: the in-memory path it was given to the library with → NAME.
  std::map<std::string, std::string> uploads;
  std::vector<std::shared_ptr<const void>> keep_alive;  // the uploads' rasters, held while the request runs
};

// The recipe as the client may see it: r.recipe.to_json() with every in-memory path given back as
// "upload:NAME" (or, with `saved`, as NAME: the file name beside a saved recipe).
json client_recipe_json(const StudioRequest& r, bool saved = false);
// `text` with every in-memory path of r's uploads replaced by "upload:NAME" (error messages).
std::string client_text(const StudioRequest& r, std::string text);

// Parses and validates a request body for `e`. Throws ApiError (4xx) naming the field; never
// anything else for bad input. Sizes are limited to s.max_preview (generate, steps) or
// s.max_export (resolve, export); bodies to s.max_body; exports to half of physical memory.
// An image stage's "path" must be "upload:NAME" with NAME in `uploads` (given to the library as its
// in-memory path) or "" (refused when run); any other path, and any colour "texture", is a 400
// naming the field, refused before parsing: the server never opens a file a client names.
StudioRequest parse_studio_request(Endpoint e, std::string_view body, const StudioSettings& s,
                                   const UploadPaths& uploads = {});

// An upload's name made safe as a file name beside a saved recipe: its last path component, with
// letters, digits, '.', '-' and '_' kept and anything else replaced by '_', at most 100 bytes, no
// leading '.'; "" when nothing is left. "recipe.json" (the saved recipe's own name) becomes
// "upload-recipe.json".
std::string upload_name(std::string_view name);

// X-Relief-Client: 1..64 characters [A-Za-z0-9_-].
bool valid_client_id(std::string_view id);

// A Content-Disposition value for a download named `filename` (built from the recipe's name, so
// any bytes): `attachment; filename="ASCII"; filename*=UTF-8''PERCENT-ENCODED` (RFC 6266/5987).
// The ASCII form keeps letters, digits, '.', '-', '_' and replaces everything else by '_'; the
// UTF-8 form keeps every character but control characters, '/', '\' and invalid bytes ('_'). No
// quote, CR or LF can reach the header; at most 200 bytes of the name are used.
std::string content_disposition(std::string_view filename);

}  // namespace relief::cli
