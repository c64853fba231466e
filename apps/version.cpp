#include "apps/version.hpp"

#include "rayline_version.hpp"  // generated in the build tree (apps/CMakeLists.txt)

namespace rayline::cli {

const char* version() { return RAYLINE_VERSION_STRING; }

}  // namespace rayline::cli
