// Error's message is "subject: reason", the form main prints after "tritrace: ".
#include "tritrace/error.h"

#include <utility>

namespace tritrace {

Error::Error(std::string subject, std::string reason, ExitCode code)
    : std::runtime_error(subject + ": " + reason),
      subject_(std::move(subject)),
      reason_(std::move(reason)),
      code_(code) {}

}  // namespace tritrace
