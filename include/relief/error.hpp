#pragma once
// relief::Error — the one exception type the library throws for bad input.
//
// Every error names the offending field with the same path syntax that `--set` accepts
// (`stages[2].octaves`, `world.size`, `seed`), states what was expected and what was given.
// The CLI prints what() and exits with code 2; the studio returns it as a 4xx JSON body.
//
// Any bytes may reach a message (a recipe key, a `--set` path, a stage name): what() and path()
// are always valid UTF-8 (invalid sequences become U+FFFD) and hold no control characters but
// line feeds (the others, NUL included, appear as \u00XX), so a message can be printed with %s
// and dumped into JSON whatever the input was.
#include <stdexcept>
#include <string>
#include <string_view>

namespace relief {

// `text` as valid UTF-8 (each invalid byte → U+FFFD) with control characters other than '\n'
// written as \u00XX; text that already qualifies is returned unchanged.
std::string printable_text(std::string_view text);

class Error : public std::runtime_error {
 public:
  // path: the field ("" when the error is not about one field); message: expected/got text.
  // what() is "PATH: MESSAGE" (just MESSAGE when the path is empty), printable (printable_text).
  Error(const std::string& path, const std::string& message)
      : std::runtime_error(printable_text(path.empty() ? message : path + ": " + message)), path_(printable_text(path)),
        message_(printable_text(message)) {}
  const std::string& path() const noexcept { return path_; }
  // The message without the path, for callers that show or re-home the path themselves (an error
  // from a nested check becomes Error(outer + "." + e.path(), e.message())).
  const std::string& message() const noexcept { return message_; }

 private:
  std::string path_;
  std::string message_;
};

}  // namespace relief
