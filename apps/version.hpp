// The version of this rayline binary: the git description of the commit it was built from
// (`git describe --tags --always --dirty`), or the project version outside git
// (cmake/RaylineVersion.cmake). Printed by --version and recorded in every metrics.json.
#pragma once

namespace rayline::cli {
const char* version();
}
