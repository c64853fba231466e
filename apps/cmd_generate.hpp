// `rayline generate NAME --triangles N --out F [--seed S]`: write a procedural scene
// (binary PLY mesh + companion scene JSON), deterministic for the seed, streaming in
// bounded memory. `rayline generate --list` names the generators.
#pragma once
#include <cstdint>
#include <string>

namespace rayline::cli {

struct GenerateOptions {
  std::string name;
  std::string triangles;   // count with optional K/M/G suffix (10^3, 10^6, 10^9); empty: generator default
  std::string out;         // mesh path (.ply)
  std::string scene_out;   // companion scene path; empty: OUT with .json; "-": none
  std::uint64_t seed = 1;
  bool list = false;
  bool quiet = false;
};
int run_generate(const GenerateOptions& opt);

// "100M" → 100000000; throws InputError(field, ...) on anything else.
std::uint64_t parse_count(const std::string& text, const std::string& field);

}  // namespace rayline::cli
