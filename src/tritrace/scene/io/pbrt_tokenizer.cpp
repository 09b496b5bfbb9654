// The pbrt-v4 tokenizer: whitespace separates tokens, '#' starts a comment to the end of the line
// (outside strings), strings are double-quoted on one line with C-style escapes, and '[' and ']'
// are tokens of their own even when written against a neighbour ("[1 2]").
#include "tritrace/scene/io/pbrt_tokenizer.h"

#include <utility>

#include "tritrace/error.h"

namespace tritrace {

std::string PbrtLocation::describe() const {
  return (file ? *file : std::string("?")) + ":" + std::to_string(line) + ":" +
         std::to_string(column);
}

std::string PbrtLocation::describe_line() const {
  return (file ? *file : std::string("?")) + ":" + std::to_string(line);
}

std::string shown_token(const PbrtToken& token) {
  std::string text = token.text.size() > 40 ? token.text.substr(0, 40) + "..." : token.text;
  for (char& ch : text) {
    if (static_cast<unsigned char>(ch) < 0x20 || static_cast<unsigned char>(ch) >= 0x7f) ch = '?';
  }
  switch (token.kind) {
    case PbrtToken::Kind::kString:
      return "\"" + text + "\"";
    case PbrtToken::Kind::kOpen:
      return "'['";
    case PbrtToken::Kind::kClose:
      return "']'";
    case PbrtToken::Kind::kWord:
      break;
  }
  return "'" + text + "'";
}

PbrtTokenizer::PbrtTokenizer(std::string text, const std::string& file)
    : text_(std::move(text)), file_(std::make_shared<const std::string>(file)) {}

void PbrtTokenizer::fail(const PbrtLocation& at, const std::string& reason) const {
  throw Error(at.describe(), reason);
}

char PbrtTokenizer::advance() {
  const char ch = text_[pos_++];
  if (ch == '\n') {
    ++line_;
    column_ = 1;
  } else {
    ++column_;
  }
  return ch;
}

void PbrtTokenizer::skip_space_and_comments() {
  while (pos_ < text_.size()) {
    const char ch = text_[pos_];
    if (ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' || ch == '\f' || ch == '\v') {
      advance();
    } else if (ch == '#') {
      while (pos_ < text_.size() && text_[pos_] != '\n') advance();
    } else {
      return;
    }
  }
}

const std::optional<PbrtToken>& PbrtTokenizer::peek() {
  if (!peeked_) peeked_ = next();
  return *peeked_;
}

std::optional<PbrtToken> PbrtTokenizer::next() {
  if (peeked_) {
    std::optional<PbrtToken> t = std::move(*peeked_);
    peeked_.reset();
    return t;
  }
  skip_space_and_comments();
  if (pos_ >= text_.size()) return std::nullopt;
  PbrtToken token;
  token.at = here();
  const char first = text_[pos_];
  if (first == '[' || first == ']') {
    advance();
    token.kind = first == '[' ? PbrtToken::Kind::kOpen : PbrtToken::Kind::kClose;
    token.text = std::string(1, first);
    return token;
  }
  if (first == '"') {
    token.kind = PbrtToken::Kind::kString;
    advance();
    while (true) {
      if (pos_ >= text_.size() || text_[pos_] == '\n') {
        fail(token.at, "unterminated string (a string ends with '\"' on the line it starts)");
      }
      const PbrtLocation at = here();
      const char ch = advance();
      if (ch == '"') break;
      if (ch != '\\') {
        token.text += ch;
        continue;
      }
      if (pos_ >= text_.size()) fail(at, "unterminated string");
      const char esc = advance();
      switch (esc) {
        case 'b':
          token.text += '\b';
          break;
        case 'f':
          token.text += '\f';
          break;
        case 'n':
          token.text += '\n';
          break;
        case 'r':
          token.text += '\r';
          break;
        case 't':
          token.text += '\t';
          break;
        case '\\':
          token.text += '\\';
          break;
        case '\'':
          token.text += '\'';
          break;
        case '"':
          token.text += '"';
          break;
        default:
          fail(at, std::string("unknown escape '\\") +
                       (static_cast<unsigned char>(esc) >= 0x20 ? std::string(1, esc) : "?") +
                       "' in a string");
      }
    }
    return token;
  }
  token.kind = PbrtToken::Kind::kWord;
  while (pos_ < text_.size()) {
    const char ch = text_[pos_];
    if (ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' || ch == '\f' || ch == '\v' ||
        ch == '"' || ch == '[' || ch == ']' || ch == '#') {
      break;
    }
    if (static_cast<unsigned char>(ch) < 0x20) {
      fail(here(), "unexpected control character (byte " +
                       std::to_string(static_cast<unsigned char>(ch)) + ")");
    }
    token.text += advance();
  }
  return token;
}

}  // namespace tritrace
