// `rayline compare`: the same platform and workload under several schedulers (default the
// paper's three: gmb, budge, loadanyonce), one `simulate` run each, side by side.
#pragma once
#include <string>

#include "apps/cmd_simulate.hpp"

namespace rayline::cli {

struct CompareOptions {
  SimulateOptions sim;                          // everything but --scheduler and --out
  std::string schedulers = "gmb,budge,loadanyonce";
  std::string out = "out/compare";
};
int run_compare(const CompareOptions& opt);

}  // namespace rayline::cli
