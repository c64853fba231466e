// `rayline calibrate --distributed` (render/mpi/README.md, "Calibrating the LAN"): Eq. 1's
// two terms for the channel between every pair of ranks, by ping-pong: latency = half the
// median round trip of 8 bytes, bandwidth = 4 MiB over (half the median round trip of 4 MiB
// minus the latency). The platform file gets one switched LAN with the median latency of
// all pairs and, per rank, a NIC speed: the median bandwidth of the pairs it is part of.
#pragma once
#include <utility>
#include <vector>

#include "render/engine/workstation.hpp"
#include "render/mpi/comm.hpp"

namespace rayline::mpi {

struct LanMeasurement {
  int ranks = 1;
  std::vector<std::vector<double>> latency, bandwidth;  // [i][j], i != j (rank 0 only)
  engine::LanModel model;                               // what the platform file gets
};

// Eq. 1's two terms of the channel to `peer`: (latency, bandwidth) as measured here, while
// `peer` runs echo_pair with this rank (the receiver threads not running).
std::pair<double, double> measure_pair(Comm& comm, int peer, int round_trips = 31);
void echo_pair(Comm& comm, int peer, int round_trips = 31);

// Collective. The full result on rank 0; the other ranks get `ranks` only.
LanMeasurement measure_lan(const Session& s, int round_trips = 31);

}  // namespace rayline::mpi
