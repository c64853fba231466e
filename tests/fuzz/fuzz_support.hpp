// Shared by the fuzz targets (tests/fuzz/, docs/fuzzing.md): a scratch folder per process
// for the loaders that take a path, and the rule that tells a finding from a clean refusal.
//
// A clean refusal is rayline::InputError, the error the command line turns into exit 2
// (common/error.hpp). Any other exception escaping a loader would be exit 1 or a crash,
// so it is reported and the process aborts: libFuzzer saves the input, and the replay
// test fails naming it.
#pragma once
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <typeinfo>

#include "common/error.hpp"

namespace rayline::fuzz {

// $TMPDIR/rayline-fuzz-<pid>/, made on first use and removed when the process exits
// normally (libFuzzer ends crashes with _exit; the folder then stays, named by the pid).
inline const std::filesystem::path& scratch_dir() {
  // Never destroyed: the exit handler below still needs it after static destructors ran.
  static const std::filesystem::path* const dir = [] {
    std::error_code ec;
    std::filesystem::path base = std::filesystem::temp_directory_path(ec);
    if (ec) base = "/tmp";
    auto* d = new std::filesystem::path(base / ("rayline-fuzz-" + std::to_string(::getpid())));
    std::filesystem::create_directories(*d);
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(scratch_dir(), ignored);
    });
    return d;
  }();
  return *dir;
}

// Writes the input to scratch_dir()/name (replacing what was there) and returns its path.
inline std::string write_input(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::string path = (scratch_dir() / name).string();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s (scratch folder full?)\n", path.c_str());
    std::abort();
  }
  return path;
}

inline void remove_path(const std::string& path) {
  std::error_code ignored;
  std::filesystem::remove_all(path, ignored);
}

// Runs `body`; an InputError is the documented clean failure, anything else a finding.
template <class Body>
void expect_clean(const char* target, Body&& body) {
  try {
    body();
  } catch (const InputError&) {
    // exit 2 with a message naming the file: a normal outcome for bad bytes
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz %s: FINDING: %s escaped (not an InputError): %s\n", target, typeid(e).name(), e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "fuzz %s: FINDING: a non-std exception escaped\n", target);
    std::abort();
  }
}

}  // namespace rayline::fuzz
