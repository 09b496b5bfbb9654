// CLI11's side of the settings: a library checker (tritrace/job/setting_values.h,
// tritrace/job/job_settings.h) as a validator, and CLI11's parse errors as one line.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>

#include "tritrace/job/setting_values.h"

namespace tritrace::cli {

// A CLI11 parse error as one line that names the flag first where CLI11 gives one: unknown
// arguments and missing values reworded, newlines flattened. Both apps print it after their name.
std::string one_line_usage_message(const CLI::ParseError& e);

// A checker as a CLI11 validator (no description of its own: --help shows the option's text).
CLI::Validator checked(std::function<std::string(std::string&)> check);
// The library's checker of a setting (job_settings.h) as a validator.
CLI::Validator checked(std::string (*check)(const std::string&));

}  // namespace tritrace::cli
