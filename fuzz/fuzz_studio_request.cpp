// Fuzz target: what a client can send to `relief studio` — the JSON bodies of POST /api/resolve,
// /api/generate, /api/steps and /api/export (parse_studio_request), the X-Relief-Client header and
// the preset name of GET /api/presets/NAME (load_preset).
//
// Input: a first line naming the request, then the body:
//   "POST /api/generate\n{…}"      (resolve, generate, steps, export)
//   "GET /api/presets/NAME"        (NAME as the server hands it over, e.g. "../../etc/passwd")
//   "CLIENT ID"                    (the X-Relief-Client header value)
// Any other first line is sent to /api/generate whole (so byte-level mutations of the first line
// still exercise the parser). Passes when the request is accepted or refused with relief::Error
// (the studio's ApiError is one); any other exception escapes.
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <string>

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
    } else {
      Endpoint e = Endpoint::Generate;
      std::string body = text;
      if (first == "POST /api/resolve") e = Endpoint::Resolve, body = rest;
      else if (first == "POST /api/generate") e = Endpoint::Generate, body = rest;
      else if (first == "POST /api/steps") e = Endpoint::Steps, body = rest;
      else if (first == "POST /api/export") e = Endpoint::Export, body = rest;
      const StudioRequest r = parse_studio_request(e, body, s);
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
