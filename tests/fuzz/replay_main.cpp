// Runs a fuzz target over files, without libFuzzer: `fuzz_X PATH...` feeds every regular
// file under each PATH (folders recursively, in name order) to LLVMFuzzerTestOneInput once.
// This is how the committed corpus (tests/fuzz/corpus/<target>/) runs as a ctest with any
// compiler, and under -DRAYLINE_SANITIZE=ON. A finding aborts (fuzz_support.hpp) or is a
// sanitizer report; the input's name is printed before it runs, so the log names it.
// Exit 0 when every input ran, 2 on bad usage or an unreadable path.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc, char*** argv);

namespace {

namespace fs = std::filesystem;

bool collect(const fs::path& p, std::vector<fs::path>& out) {
  std::error_code ec;
  if (fs::is_regular_file(p, ec)) {
    out.push_back(p);
    return true;
  }
  if (!fs::is_directory(p, ec)) return false;
  std::vector<fs::path> here;
  for (fs::recursive_directory_iterator it(p, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_regular_file(ec)) here.push_back(it->path());
  if (ec) return false;
  std::sort(here.begin(), here.end());
  out.insert(out.end(), here.begin(), here.end());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    std::fprintf(argc < 2 ? stderr : stdout,
                 "usage: %s FILE_OR_FOLDER...\n"
                 "Runs this fuzz target once on every file (folders recursively). Built without libFuzzer;\n"
                 "scripts/fuzz.sh builds the libFuzzer version (docs/fuzzing.md).\n",
                 argv[0]);
    return argc < 2 ? 2 : 0;
  }
  if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
  std::vector<fs::path> inputs;
  for (int i = 1; i < argc; ++i)
    if (!collect(argv[i], inputs)) {
      std::fprintf(stderr, "replay: %s: not a readable file or folder\n", argv[i]);
      return 2;
    }
  double slowest = 0;
  std::string slowest_name;
  const auto t_all = std::chrono::steady_clock::now();
  for (const fs::path& p : inputs) {
    std::ifstream in(p, std::ios::binary);
    const std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    if (in.bad()) {
      std::fprintf(stderr, "replay: %s: cannot read\n", p.c_str());
      return 2;
    }
    std::fprintf(stderr, "replay: %s (%zu bytes)\n", p.c_str(), bytes.size());
    const auto t0 = std::chrono::steady_clock::now();
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (s > slowest) slowest = s, slowest_name = p.string();
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_all).count();
  std::printf("replay: %zu inputs in %.2f s, none a finding (slowest %.3f s: %s)\n", inputs.size(), total, slowest,
              slowest_name.c_str());
  return 0;
}
