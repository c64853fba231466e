// Timing model of Sec. 3.2.
//   Eq. 1  T_TRANS(d_i -> d_j, w) = T_LAT + |w| / T_BW           (DeviceGraph::transfer_time)
//   Eq. 2  T_EXEC(d, j, W) = 0 if W is empty,
//                           T_SETUP(d, j) + T_RATE(d, j) . (|w_1|, |w_2|, ...) otherwise
// Our choice for the weight vector T_RATE: one coefficient (seconds per byte) per
// DataKind of input, so RayIntersect(SceneData_b, RayQueue_b) costs
// setup + rate[SceneData]*|scene| + rate[RayQueue]*|rays|; two inputs of one kind add.
#pragma once
#include <array>
#include <span>
#include <string>
#include <vector>

#include "sched/core/data_block.hpp"
#include "sched/core/fit_errors.hpp"
#include "sched/core/types.hpp"

namespace rayline {

struct ExecCoefficients {
  bool supported = false;                        // may this device run this job type?
  Time setup = 0;                                // T_SETUP(d, j), seconds
  std::array<double, kDataKindCount> rate{};     // T_RATE(d, j), seconds per byte per DataKind
};

struct InputSize {
  DataKind kind;
  Bytes bytes;
};

// One measured execution, for fit(): job type, device, its input sizes and duration.
struct TimingSample {
  DeviceId device = kNone;
  JobTypeId type = kNone;
  std::vector<InputSize> inputs;
  Time duration = 0;
};

struct FitReport {
  struct Entry {
    DeviceId device;
    JobTypeId type;
    int samples;
    double rms_error;        // seconds
    double max_rel_error;    // max |pred - meas| / meas (the shortest samples; sched/core/fit_errors.hpp)
    bool ok;                 // false: too few samples or singular system
    FitErrors errors;        // the whole summary: median, time-weighted, RMS, worst (NaN if not ok)
  };
  std::vector<Entry> entries;
  double worst_rel_error = 0;
};

class TimingModel {
 public:
  void resize(int devices, int job_types);
  int devices() const { return devices_; }
  int job_types() const { return types_; }

  ExecCoefficients& at(DeviceId d, JobTypeId j) { return coef_[index(d, j)]; }
  const ExecCoefficients& at(DeviceId d, JobTypeId j) const { return coef_[index(d, j)]; }
  bool supports(DeviceId d, JobTypeId j) const {
    return j >= 0 && j < types_ && coef_[index(d, j)].supported;
  }

  // Eq. 2.
  Time exec_time(DeviceId d, JobTypeId j, std::span<const InputSize> inputs) const;
  Time setup_time(DeviceId d, JobTypeId j) const { return at(d, j).setup; }
  // Every (device, job type) entry, device-major.
  std::span<const ExecCoefficients> coefficients() const { return coef_; }

  // Non-negative least-squares fit (sched/core/nnls.hpp) of T_SETUP and T_RATE per (device, job
  // type) from samples; replaces the coefficients it could fit and reports the fit error of each.
  FitReport fit(std::span<const TimingSample> samples);

 private:
  std::size_t index(DeviceId d, JobTypeId j) const {
    return static_cast<std::size_t>(d) * static_cast<std::size_t>(types_) + static_cast<std::size_t>(j);
  }
  int devices_ = 0, types_ = 0;
  std::vector<ExecCoefficients> coef_;
};

}  // namespace rayline
