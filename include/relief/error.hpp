#pragma once
// relief::Error — the one exception type the library throws for bad input.
//
// Every error names the offending field with the same path syntax that `--set` accepts
// (`stages[2].octaves`, `world.size`, `seed`), states what was expected and what was given.
// The CLI prints what() and exits with code 2; the studio returns it as a 4xx JSON body.
#include <stdexcept>
#include <string>

namespace relief {

class Error : public std::runtime_error {
 public:
  // path: the field ("" when the error is not about one field); message: expected/got text.
  // what() is "PATH: MESSAGE" (just MESSAGE when the path is empty).
  Error(std::string path, std::string message)
      : std::runtime_error(path.empty() ? message : path + ": " + message), path_(std::move(path)),
        message_(std::move(message)) {}
  const std::string& path() const noexcept { return path_; }
  // The message without the path, for callers that show or re-home the path themselves (an error
  // from a nested check becomes Error(outer + "." + e.path(), e.message())).
  const std::string& message() const noexcept { return message_; }

 private:
  std::string path_;
  std::string message_;
};

}  // namespace relief
