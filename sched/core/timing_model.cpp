// Timing model of Sec. 3.2 (Eq. 2) and its least-squares fit (Sec. 6: "the architecture-
// specific model constants T_SETUP(d, j) and T_RATE(d, j) are fitted using the least
// square method"). The solver (non-negative least squares, Eigen inside) is sched/core/nnls.cpp.
#include "sched/core/timing_model.hpp"

#include "sched/core/fit_errors.hpp"
#include "sched/core/nnls.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

namespace rayline {

namespace {

// Bytes of each DataKind in W; two inputs of one kind add (see the header).
std::array<double, kDataKindCount> bytes_per_kind(std::span<const InputSize> inputs) {
  std::array<double, kDataKindCount> b{};
  for (const InputSize& in : inputs) {
    const int k = static_cast<int>(in.kind);
    if (k < 0 || k >= kDataKindCount) throw std::invalid_argument("TimingModel: input of unknown DataKind");
    b[static_cast<std::size_t>(k)] += static_cast<double>(in.bytes);
  }
  return b;
}

// Eq. 2's "W = 0" case. We read it as "W carries no payload": no input blocks at all, or
// only zero-size ones (e.g. an empty ray queue). Such a job does no work, so it costs 0 and
// in particular pays no T_SETUP. A job with at least one non-empty input pays the setup.
bool is_empty_workload(const std::array<double, kDataKindCount>& b) {
  return std::all_of(b.begin(), b.end(), [](double x) { return x == 0.0; });
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

void TimingModel::resize(int devices, int job_types) {
  if (devices < 0 || job_types < 0) throw std::invalid_argument("TimingModel::resize: negative size");
  // Keep the coefficients of every (device, job type) that survives the resize, so that
  // DeviceGraph::add_job_type() does not wipe timings loaded for the existing types.
  std::vector<ExecCoefficients> next(static_cast<std::size_t>(devices) * static_cast<std::size_t>(job_types));
  const int keep_d = std::min(devices, devices_), keep_j = std::min(job_types, types_);
  for (int d = 0; d < keep_d; ++d)
    for (int j = 0; j < keep_j; ++j)
      next[static_cast<std::size_t>(d) * static_cast<std::size_t>(job_types) + static_cast<std::size_t>(j)] =
          coef_[index(d, j)];
  coef_ = std::move(next);
  devices_ = devices;
  types_ = job_types;
}

// Eq. 2: T_EXEC(d, j, W) = 0 if W is empty, T_SETUP(d, j) + T_RATE(d, j) . (|w_1|, |w_2|, ...)
// otherwise. "Empty" = no inputs or all inputs of size 0 (see is_empty_workload). The empty
// case is answered first and holds for any (d, j). For a non-empty W on a device that cannot
// run the job type (supported == false, or ids out of range) the time is kNever.
Time TimingModel::exec_time(DeviceId d, JobTypeId j, std::span<const InputSize> inputs) const {
  const auto b = bytes_per_kind(inputs);
  if (is_empty_workload(b)) return 0;
  if (d < 0 || d >= devices_ || j < 0 || j >= types_) return kNever;
  const ExecCoefficients& c = coef_[index(d, j)];
  if (!c.supported) return kNever;
  Time t = c.setup;
  for (std::size_t k = 0; k < static_cast<std::size_t>(kDataKindCount); ++k) t += c.rate[k] * b[k];
  return t;
}

// Least squares per (device, job type):
//   min_x || A x - t ||^2,  A row = [1, bytes of kind k_1, bytes of kind k_2, ...],
// with one column per DataKind that is non-zero in at least one sample of the group (kinds
// never present cannot be identified and get rate 0). Samples whose W is empty are not
// used: Eq. 2 predicts 0 for them whatever the coefficients, so they carry no information.
//
// Non-negativity: a negative setup or rate is meaningless, so the fit is the exact
// non-negative least-squares optimum (Lawson-Hanson NNLS, sched/core/nnls.cpp; columns scaled to
// unit max-abs inside, so that rank detection is not fooled by the 1 vs 1e9-byte
// magnitudes). Dropping the most negative coefficient and refitting instead would leave no way
// back for a dropped column: with three or more columns that can miss the optimum
// (TimingModelFit.IsTheNonNegativeOptimum).
//
// Not fitted (ok = false, old coefficients left untouched, errors NaN): fewer usable samples
// than unknowns, or A rank deficient (e.g. all samples have the same ray count, making the
// rate column collinear with the setup column).
FitReport TimingModel::fit(std::span<const TimingSample> samples) {
  // Group samples by (device, type); std::map keeps the report ordered by device then type.
  std::map<std::pair<DeviceId, JobTypeId>, std::vector<const TimingSample*>> groups;
  for (const TimingSample& s : samples) {
    if (s.device < 0 || s.device >= devices_ || s.type < 0 || s.type >= types_)
      throw std::invalid_argument("TimingModel::fit: sample with device/job type out of range");
    if (!std::isfinite(s.duration) || s.duration < 0)
      throw std::invalid_argument("TimingModel::fit: sample with negative or non-finite duration");
    groups[{s.device, s.type}].push_back(&s);
  }

  FitReport report;
  for (const auto& [key, group] : groups) {
    FitReport::Entry e{key.first, key.second, 0, kNaN, kNaN, false, {}};

    // Usable rows and the per-kind byte sums.
    std::vector<std::array<double, kDataKindCount>> rows;
    std::vector<double> times;
    std::array<bool, kDataKindCount> present{};
    for (const TimingSample* s : group) {
      const auto b = bytes_per_kind(s->inputs);
      if (is_empty_workload(b)) continue;
      for (std::size_t k = 0; k < b.size(); ++k) present[k] = present[k] || b[k] != 0;
      rows.push_back(b);
      times.push_back(s->duration);
    }
    e.samples = static_cast<int>(rows.size());

    // Unknowns: column 0 = setup, then one column per present kind.
    std::vector<int> kind_of_col = {-1};
    for (int k = 0; k < kDataKindCount; ++k)
      if (present[static_cast<std::size_t>(k)]) kind_of_col.push_back(k);
    const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(rows.size());
    const std::ptrdiff_t m = static_cast<std::ptrdiff_t>(kind_of_col.size());
    if (n < m) {
      report.entries.push_back(e);
      continue;
    }

    std::vector<double> a(static_cast<std::size_t>(n * m));
    for (std::ptrdiff_t r = 0; r < n; ++r)
      for (std::ptrdiff_t c = 0; c < m; ++c) {
        const int k = kind_of_col[static_cast<std::size_t>(c)];
        a[static_cast<std::size_t>(r * m + c)] = k < 0 ? 1.0 : rows[static_cast<std::size_t>(r)][static_cast<std::size_t>(k)];
      }
    const NnlsResult nn = solve_nnls(a, static_cast<int>(n), static_cast<int>(m), times);
    if (!nn.ok) {
      report.entries.push_back(e);
      continue;
    }
    const std::vector<double>& x = nn.x;

    ExecCoefficients& coef = coef_[index(key.first, key.second)];
    coef.supported = true;
    coef.setup = x[0];
    coef.rate.fill(0.0);
    for (std::ptrdiff_t c = 1; c < m; ++c)
      coef.rate[static_cast<std::size_t>(kind_of_col[static_cast<std::size_t>(c)])] = x[static_cast<std::size_t>(c)];

    // Errors against the measurements (sched/core/fit_errors.hpp).
    std::vector<double> pred(rows.size());
    for (std::size_t r = 0; r < rows.size(); ++r) {
      pred[r] = coef.setup;
      for (std::size_t k = 0; k < static_cast<std::size_t>(kDataKindCount); ++k) pred[r] += coef.rate[k] * rows[r][k];
    }
    const FitErrors fe = fit_errors(pred, times);
    e.errors = fe;
    e.rms_error = fe.rms;
    e.max_rel_error = std::isnan(fe.max_rel) ? 0.0 : fe.max_rel;  // no sample > 0: nothing to be relative to
    e.ok = true;
    if (fe.max_rel > report.worst_rel_error) report.worst_rel_error = fe.max_rel;
    report.entries.push_back(e);
  }
  return report;
}

}  // namespace rayline
