// CLI11 glue for the library's setting checkers.
#include "flags/flag_values.h"

namespace tritrace::cli {

std::string one_line_usage_message(const CLI::ParseError& e) {
  std::string msg = e.what();
  if (dynamic_cast<const CLI::ExtrasError*>(&e)) {
    const size_t colon = msg.find(": ");
    const std::string args = colon == std::string::npos ? msg : msg.substr(colon + 2);
    return args + ": unknown option or argument (see --help)";
  }
  if (dynamic_cast<const CLI::ArgumentMismatch*>(&e) && msg.find(" missing") != std::string::npos) {
    return msg.substr(0, msg.find(": ")) + ": missing value";
  }
  for (char& c : msg) {
    if (c == '\n') c = ' ';
  }
  return msg;
}

CLI::Validator checked(std::function<std::string(std::string&)> check) {
  return CLI::Validator(std::move(check), "", "");
}

CLI::Validator checked(std::string (*check)(const std::string&)) {
  return checked(
      std::function<std::string(std::string&)>([check](std::string& text) { return check(text); }));
}

}  // namespace tritrace::cli
