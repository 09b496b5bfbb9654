// The lexical layer of pbrt-v4 scene files: splits a file's text into directives, quoted strings,
// numbers and brackets, each with the file, line and column where it starts, so that every later
// error can name the place ("scene.pbrt:12:5: reason") as the format's users expect.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace tritrace {

// Where a token starts: 1-based line and column (columns count bytes).
struct PbrtLocation {
  std::shared_ptr<const std::string> file;  // shared by every token of the file
  int line = 0;
  int column = 0;

  // "FILE:LINE:COL", the subject of errors and warnings.
  std::string describe() const;
  // "FILE:LINE", for warnings that name where a kind of thing first appears.
  std::string describe_line() const;
};

struct PbrtToken {
  enum class Kind {
    kWord,    // a bare word: a directive name, a number, true/false
    kString,  // "..." with its escapes resolved; `text` holds the contents
    kOpen,    // [
    kClose,   // ]
  };
  Kind kind = Kind::kWord;
  std::string text;
  PbrtLocation at;
};

// Reads tokens one at a time from a whole file's text (which it keeps a copy of).
class PbrtTokenizer {
 public:
  PbrtTokenizer(std::string text, const std::string& file);

  // The next token, or nullopt at the end of the text. Throws Error("FILE:LINE:COL", reason) for
  // an unterminated string, a bad escape or a control character.
  std::optional<PbrtToken> next();
  // The next token without consuming it.
  const std::optional<PbrtToken>& peek();

  // Where the text ends (for "unexpected end of file").
  PbrtLocation end_location() const { return here(); }
  const std::shared_ptr<const std::string>& file() const { return file_; }

 private:
  PbrtLocation here() const { return {file_, line_, column_}; }
  void skip_space_and_comments();
  char advance();
  [[noreturn]] void fail(const PbrtLocation& at, const std::string& reason) const;

  std::string text_;
  std::shared_ptr<const std::string> file_;
  size_t pos_ = 0;
  int line_ = 1;
  int column_ = 1;
  std::optional<std::optional<PbrtToken>> peeked_;
};

// The token as it appears in a file, for messages: strings quoted, long ones cut.
std::string shown_token(const PbrtToken& token);

}  // namespace tritrace
