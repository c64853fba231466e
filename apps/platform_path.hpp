// Resolve a --platform argument: an existing path, or a built-in name such as
// "paper-cluster" / "paper-A" looked up among the platform files (apps/data_dir.hpp).
#pragma once
#include <string>

namespace rayline::cli {
std::string resolve_platform(const std::string& arg);  // empty arg: paper-cluster
}
