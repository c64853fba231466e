// What started this process: the rayline version and its command line, recorded once by
// the command's main() and written into every metrics.json (so a result says how it was
// made). Empty when nothing recorded them (library use, tests).
#pragma once
#include <string>

namespace rayline {

void record_invocation(const std::string& version, int argc, const char* const* argv);
const std::string& invocation_version();
// The arguments joined by spaces, each quoted (') when it holds a space or a shell character.
const std::string& invocation_command();

}  // namespace rayline
