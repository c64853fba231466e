// Timing model of Sec. 3.2 (Eq. 2) and its least-squares fit (Sec. 6: "the architecture-
// specific model constants T_SETUP(d, j) and T_RATE(d, j) are fitted using the least
// square method"). Eigen is used here only; the header stays Eigen-free.
#include "sched/timing_model.hpp"

#include <Eigen/Dense>

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
// Columns are scaled to unit max-abs before a column-pivoting QR so that rank detection
// is not fooled by the 1 vs 1e9-byte magnitudes; the solution is unscaled afterwards.
//
// Non-negativity ("NNLS-lite"): a negative setup or rate is meaningless, so while the
// solution has a negative coefficient, the most negative one is fixed to 0 (its column is
// dropped) and the remaining columns are refitted. This is an active-set heuristic without
// the re-activation step of Lawson-Hanson NNLS: it always terminates with x >= 0 (A >= 0,
// t >= 0) but is not guaranteed to be the exact NNLS optimum when several columns compete.
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
    FitReport::Entry e{key.first, key.second, 0, kNaN, kNaN, false};

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
    const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
    const Eigen::Index m = static_cast<Eigen::Index>(kind_of_col.size());
    if (n < m) {
      report.entries.push_back(e);
      continue;
    }

    Eigen::MatrixXd A(n, m);
    Eigen::VectorXd t(n);
    for (Eigen::Index r = 0; r < n; ++r) {
      t(r) = times[static_cast<std::size_t>(r)];
      for (Eigen::Index c = 0; c < m; ++c) {
        const int k = kind_of_col[static_cast<std::size_t>(c)];
        A(r, c) = k < 0 ? 1.0 : rows[static_cast<std::size_t>(r)][static_cast<std::size_t>(k)];
      }
    }
    Eigen::VectorXd scale(m);
    for (Eigen::Index c = 0; c < m; ++c) {
      const double s = A.col(c).cwiseAbs().maxCoeff();
      scale(c) = s > 0 ? s : 1.0;
      A.col(c) /= scale(c);
    }

    constexpr double kRankThreshold = 1e-9;  // relative to the largest pivot
    auto solve = [&](const std::vector<Eigen::Index>& cols, Eigen::VectorXd& x, bool& full_rank) {
      Eigen::MatrixXd Asub(n, static_cast<Eigen::Index>(cols.size()));
      for (std::size_t i = 0; i < cols.size(); ++i) Asub.col(static_cast<Eigen::Index>(i)) = A.col(cols[i]);
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Asub.rows(), Asub.cols());
      qr.setThreshold(kRankThreshold);
      qr.compute(Asub);
      full_rank = qr.rank() == Asub.cols();
      x = full_rank ? Eigen::VectorXd(qr.solve(t)) : Eigen::VectorXd();
    };

    std::vector<Eigen::Index> active(static_cast<std::size_t>(m));
    for (Eigen::Index c = 0; c < m; ++c) active[static_cast<std::size_t>(c)] = c;
    Eigen::VectorXd xs;
    bool full_rank = false;
    solve(active, xs, full_rank);
    if (!full_rank) {
      report.entries.push_back(e);
      continue;
    }
    // NNLS-lite: drop the most negative coefficient and refit. A subset of independent
    // columns stays independent; the rank check is kept only as a numerical safety net.
    while (full_rank && !active.empty()) {
      Eigen::Index worst = 0;
      const double mn = xs.minCoeff(&worst);
      if (mn >= 0) break;
      active.erase(active.begin() + worst);
      if (active.empty()) {
        xs.resize(0);
        break;
      }
      solve(active, xs, full_rank);
    }
    if (!full_rank) {
      report.entries.push_back(e);
      continue;
    }

    Eigen::VectorXd x = Eigen::VectorXd::Zero(m);
    for (std::size_t i = 0; i < active.size(); ++i)
      x(active[i]) = xs(static_cast<Eigen::Index>(i)) / scale(active[i]);

    ExecCoefficients& coef = coef_[index(key.first, key.second)];
    coef.supported = true;
    coef.setup = x(0);
    coef.rate.fill(0.0);
    for (Eigen::Index c = 1; c < m; ++c)
      coef.rate[static_cast<std::size_t>(kind_of_col[static_cast<std::size_t>(c)])] = x(c);

    // Errors against the measurements, in the original (unscaled) units.
    double sq = 0, max_rel = 0;
    for (std::size_t r = 0; r < rows.size(); ++r) {
      double pred = coef.setup;
      for (std::size_t k = 0; k < static_cast<std::size_t>(kDataKindCount); ++k) pred += coef.rate[k] * rows[r][k];
      const double err = pred - times[r];
      sq += err * err;
      if (times[r] > 0) max_rel = std::max(max_rel, std::abs(err) / times[r]);
    }
    e.rms_error = std::sqrt(sq / static_cast<double>(rows.size()));
    e.max_rel_error = max_rel;
    e.ok = true;
    report.worst_rel_error = std::max(report.worst_rel_error, max_rel);
    report.entries.push_back(e);
  }
  return report;
}

}  // namespace rayline
