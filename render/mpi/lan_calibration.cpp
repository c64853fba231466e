#include "render/mpi/lan_calibration.hpp"

#include <algorithm>
#include <tuple>

namespace rayline::mpi {

namespace {
double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}
constexpr std::size_t kBig = std::size_t(4) << 20;
int big_trips(int round_trips) { return std::max(3, round_trips / 4); }
}  // namespace

std::pair<double, double> measure_pair(Comm& comm, int peer, int round_trips) {
  const double lat = median(comm.ping(peer, 8, round_trips)) / 2;
  const double big = median(comm.ping(peer, kBig, big_trips(round_trips))) / 2;
  return {lat, double(kBig) / std::max(big - lat, 1e-9)};
}

void echo_pair(Comm& comm, int peer, int round_trips) {
  comm.echo(peer, 8, round_trips);
  comm.echo(peer, kBig, big_trips(round_trips));
}

LanMeasurement measure_lan(const Session& s, int round_trips) {
  Comm comm(s);
  const int n = s.size();
  LanMeasurement m;
  m.ranks = n;
  // Rank i measures every j > i in turn; the others wait at the barrier.
  std::vector<double> mine(std::size_t(2 * n), 0.0);  // latency, bandwidth to each rank
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      if (s.rank() == i) std::tie(mine[std::size_t(2 * j)], mine[std::size_t(2 * j + 1)]) = measure_pair(comm, j, round_trips);
      else if (s.rank() == j) echo_pair(comm, i, round_trips);
      comm.barrier();
    }
  const std::vector<double> all = comm.gather(mine);
  if (s.rank() != 0) return m;
  m.latency.assign(std::size_t(n), std::vector<double>(std::size_t(n), 0.0));
  m.bandwidth = m.latency;
  std::vector<double> lats;
  std::vector<std::vector<double>> per_rank(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const double lat = all[std::size_t(i * 2 * n + 2 * j)], bw = all[std::size_t(i * 2 * n + 2 * j + 1)];
      m.latency[std::size_t(i)][std::size_t(j)] = m.latency[std::size_t(j)][std::size_t(i)] = lat;
      m.bandwidth[std::size_t(i)][std::size_t(j)] = m.bandwidth[std::size_t(j)][std::size_t(i)] = bw;
      lats.push_back(lat);
      per_rank[std::size_t(i)].push_back(bw);
      per_rank[std::size_t(j)].push_back(bw);
    }
  if (n > 1) {
    m.model.latency = median(lats);
    m.model.nic.clear();
    for (int r = 0; r < n; ++r) m.model.nic.push_back(median(per_rank[std::size_t(r)]));
    m.model.bandwidth = median(m.model.nic);
  }
  return m;
}

}  // namespace rayline::mpi
