// Where the rayline binary finds its data files (platforms/, scenes/): in $ENV_VAR when
// that is set; else installed beside the binary, <bin>/../share/rayline/<kind> (the folder
// of /proc/self/exe); else in the source tree the binary was built from (the build tree).
#pragma once
#include <string>
#include <vector>

namespace rayline::cli {

// The folders searched for `kind` ("platforms" or "scenes"), in order.
std::vector<std::string> data_dirs(const std::string& kind, const char* env_var);

// The path of `file` in the first of data_dirs(kind, env_var) that holds it. Otherwise an
// InputError on `flag` saying that `name` is neither a file nor a built-in, and every folder
// searched.
std::string find_data_file(const std::string& kind, const char* env_var, const std::string& file,
                           const std::string& flag, const std::string& name);

}  // namespace rayline::cli
