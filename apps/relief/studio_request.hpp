#pragma once
// The studio's request parsing, apart from the HTTP server so that tests and fuzz targets can
// drive it (fuzz/fuzz_studio_request.cpp). Everything a client sends is read here: the JSON body of
// POST /api/resolve, /api/generate, /api/steps and /api/export, and the X-Relief-Client header.
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

enum class Endpoint { Resolve, Generate, Steps, Export };

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
};

// Parses and validates a request body for `e`. Throws ApiError (4xx) naming the field; never
// anything else for bad input. Sizes are limited to s.max_preview (generate, steps) or
// s.max_export (resolve, export); bodies to s.max_body; exports to half of physical memory.
StudioRequest parse_studio_request(Endpoint e, std::string_view body, const StudioSettings& s);

// X-Relief-Client: 1..64 characters [A-Za-z0-9_-].
bool valid_client_id(std::string_view id);

// A Content-Disposition value for a download named `filename` (built from the recipe's name, so
// any bytes): `attachment; filename="ASCII"; filename*=UTF-8''PERCENT-ENCODED` (RFC 6266/5987).
// The ASCII form keeps letters, digits, '.', '-', '_' and replaces everything else by '_'; the
// UTF-8 form keeps every character but control characters, '/', '\' and invalid bytes ('_'). No
// quote, CR or LF can reach the header; at most 200 bytes of the name are used.
std::string content_disposition(std::string_view filename);

}  // namespace relief::cli
