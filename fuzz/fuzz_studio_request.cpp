// Fuzz target: what a client can send to `relief studio` — the JSON bodies of POST /api/resolve,
// /api/generate, /api/steps and /api/export (parse_studio_request), the X-Relief-Client header and
// the preset name of GET /api/presets/NAME (load_preset).
//
// Input: a first line naming the request, then the body:
//   "POST /api/generate\n{…}"      (resolve, generate, steps, export)
//   "GET /api/presets/NAME"        (NAME as the server hands it over, e.g. "../../etc/passwd")
//   "CLIENT ID"                    (the X-Relief-Client header value)
//   "UPLOAD NAME"                  (an upload's ?name=, made safe by upload_name)
// Request bodies may name the upload "upload:a.png" (the session holds one upload of that name);
// accepted requests are also turned back into the client's recipe (as sent and as saved).
// Any other first line is sent to /api/generate whole (so byte-level mutations of the first line
// still exercise the parser). Passes when the request is accepted or refused with relief::Error
// (the studio's ApiError is one); any other exception escapes.
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <string>

#include "relief/image.hpp"
#include "relief/params.hpp"
#include "relief/recipe.hpp"
#include "studio_request.hpp"

using namespace relief;
using namespace relief::cli;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::size_t nl = text.find('\n');
  const std::string first = text.substr(0, nl), rest = nl == std::string::npos ? "" : text.substr(nl + 1);
  StudioSettings s;
  s.max_body = 1u << 16;  // keeps every case small; the limit itself is tested on the way
  try {
    if (first.rfind("GET /api/presets/", 0) == 0) {
      (void)load_preset(first.substr(17));
    } else if (first.rfind("CLIENT ", 0) == 0) {
      (void)valid_client_id(first.substr(7));
    } else if (first.rfind("UPLOAD ", 0) == 0) {
      // The promise of upload_name: a plain file name, never a path, never the saved recipe's own.
      const std::string n = upload_name(text.substr(7));
      if (n.size() > 100 || n.find('/') != std::string::npos || n.find('\\') != std::string::npos ||
          (!n.empty() && n[0] == '.') || n == "recipe.json" || !is_utf8(n)) {
        std::fprintf(stderr, "fuzz_studio_request: upload_name gave an unsafe name\n");
        std::abort();
      }
    } else {
      Endpoint e = Endpoint::Generate;
      std::string body = text;
      if (first == "POST /api/resolve") e = Endpoint::Resolve, body = rest;
      else if (first == "POST /api/generate") e = Endpoint::Generate, body = rest;
      else if (first == "POST /api/steps") e = Endpoint::Steps, body = rest;
      else if (first == "POST /api/export") e = Endpoint::Export, body = rest;
      else if (first == "POST /api/save") e = Endpoint::Save, body = rest;
      const UploadPaths uploads = {{"a.png", std::string(kMemoryRasterPrefix) + "fuzz/a.png"}};
      const StudioRequest r = parse_studio_request(e, body, s, uploads);
      (void)client_recipe_json(r, false).dump();
      (void)client_recipe_json(r, true).dump();
      // What the handlers rely on: a seed, a size within the endpoint's limit, a writer for exports.
      const int limit = e == Endpoint::Generate || e == Endpoint::Steps ? s.max_preview : s.max_export;
      if (!r.recipe.seed || r.frame.nx > limit || r.frame.nz > limit || (e == Endpoint::Export && !r.writer)) {
        std::fprintf(stderr, "fuzz_studio_request: accepted a request the handlers cannot serve\n");
        std::abort();
      }
    }
  } catch (const ApiError& e) {
    if (e.status() < 400 || e.status() > 499) {
      std::fprintf(stderr, "fuzz_studio_request: refusal with status %d\n", e.status());
      std::abort();
    }
  } catch (const Error&) {
    // load_preset's refusal (unknown name): fine
  }
  return 0;
}
