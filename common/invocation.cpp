#include "common/invocation.hpp"

namespace rayline {

namespace {
std::string& version() {
  static std::string v;
  return v;
}
std::string& command() {
  static std::string c;
  return c;
}
}  // namespace

void record_invocation(const std::string& v, int argc, const char* const* argv) {
  version() = v;
  std::string& c = command();
  c.clear();
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i] ? argv[i] : "";
    const bool quote = a.empty() || a.find_first_of(" \t\n'\"\\$`*?;&|<>()#~") != std::string::npos;
    if (i) c += ' ';
    if (!quote) {
      c += a;
      continue;
    }
    c += '\'';
    for (const char ch : a) {
      if (ch == '\'') c += "'\\''";
      else c += ch;
    }
    c += '\'';
  }
}

const std::string& invocation_version() { return version(); }
const std::string& invocation_command() { return command(); }

}  // namespace rayline
