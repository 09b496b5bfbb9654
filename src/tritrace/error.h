// The one exception type of tritrace: thrown at I/O and parsing boundaries, caught in main, which
// prints `tritrace: <subject>: <reason>` and exits with the error's exit code.
#pragma once

#include <stdexcept>
#include <string>

namespace tritrace {

enum class ExitCode : int { kRuntime = 1, kUsage = 2 };

class Error : public std::runtime_error {
 public:
  // `subject` is the file or flag the error is about; `reason` says what is wrong with it.
  Error(std::string subject, std::string reason, ExitCode code = ExitCode::kRuntime);

  const std::string& subject() const { return subject_; }
  const std::string& reason() const { return reason_; }
  ExitCode exit_code() const { return code_; }

 private:
  std::string subject_;
  std::string reason_;
  ExitCode code_;
};

}  // namespace tritrace
