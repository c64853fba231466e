#include "render/mpi/comm.hpp"

#include <mpi.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdio>
#include <stdexcept>

namespace rayline::mpi {

namespace {
constexpr int kTag = 7;
constexpr int kPingTag = 8;

// Sleeps a little longer each idle round, up to 50 µs: a busy rank answers within tens of
// microseconds, an idle one costs a few percent of a core.
struct Backoff {
  int us = 1;
  void idle() {
    std::this_thread::sleep_for(std::chrono::microseconds(us));
    us = us < 50 ? us * 2 : 50;
  }
  void reset() { us = 1; }
};

void check(int rc, const char* what) {
  if (rc != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + what + " failed");
}

double clock() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// Waits for a request; gives up (cancels it and returns false) once `lost` turns true.
template <class Lost>
bool wait(MPI_Request& req, Lost lost) {
  Backoff b;
  for (;;) {
    int done = 0;
    if (MPI_Test(&req, &done, MPI_STATUS_IGNORE) != MPI_SUCCESS) done = 0;
    if (done) return true;
    if (lost()) {
      MPI_Cancel(&req);
      MPI_Request_free(&req);
      return false;
    }
    b.idle();
  }
}
void wait(MPI_Request& req) {
  wait(req, [] { return false; });
}
}  // namespace

Session::Session() {
  int provided = 0;
  check(MPI_Init_thread(nullptr, nullptr, MPI_THREAD_MULTIPLE, &provided), "MPI_Init_thread");
  if (provided < MPI_THREAD_MULTIPLE) {
    MPI_Finalize();
    throw std::runtime_error("the MPI library does not support MPI_THREAD_MULTIPLE (rebuild Open MPI with threads)");
  }
  // Errors are returned, not fatal: a lost peer (mpirun --enable-recovery) is handled here.
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  MPI_Comm local;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &local);
  MPI_Comm_size(local, &local_size_);
  MPI_Comm_free(&local);
}

Session::~Session() {
  // With a rank lost, MPI_Finalize could wait for it for ever: the process just ends.
  if (!peer_lost_) MPI_Finalize();
}

std::string Session::host() const {
  char name[MPI_MAX_PROCESSOR_NAME];
  int n = 0;
  MPI_Get_processor_name(name, &n);
  return std::string(name, static_cast<std::size_t>(n));
}

void Session::abort(int code) {
  MPI_Abort(MPI_COMM_WORLD, code);
  _exit(code);
}

void Comm::start(Handler h) {
  handler_ = std::move(h);
  for (auto& t : heard_) t = clock();
  stop_ = false;
  receiver_ = std::thread([this] { receive_loop(); });
}

void Comm::stop() {
  stop_ = true;
  if (receiver_.joinable()) receiver_.join();
}

double Comm::silent_for(int rank) const {
  const double now = clock();
  double silent = now - heard_[static_cast<std::size_t>(rank)];
  const int busy = receiving_;
  if (busy >= 0 && busy != rank) silent = std::min(silent, now - receiving_since_);
  return silent;
}

void Comm::send_anyway(int dest, const Buffer& message, double seconds) {
  MPI_Request req;
  if (MPI_Isend(message.data(), static_cast<int>(message.size()), MPI_BYTE, dest, kTag, MPI_COMM_WORLD, &req) !=
      MPI_SUCCESS)
    return;
  const double until = clock() + seconds;
  wait(req, [&] { return clock() > until; });
}

void Comm::send(int dest, const Buffer& message) {
  if (message.size() > std::size_t(INT_MAX)) throw std::runtime_error("MPI: message over 2 GiB");
  const auto lost_now = [&] { return dead_[static_cast<std::size_t>(dest)].load(); };
  const std::string gone = "rank " + std::to_string(dest) + " is lost";
  if (lost_now()) throw std::runtime_error(gone);
  MPI_Request req;
  check(MPI_Isend(message.data(), static_cast<int>(message.size()), MPI_BYTE, dest, kTag, MPI_COMM_WORLD, &req),
        "MPI_Isend");
  if (!wait(req, lost_now)) throw std::runtime_error(gone);
  sent_[static_cast<std::size_t>(dest)].messages.fetch_add(1);
  sent_[static_cast<std::size_t>(dest)].bytes.fetch_add(message.size());
}

void Comm::receive_loop() {
  Backoff b;
  while (!stop_) {
    int found = 0;
    MPI_Message msg;
    MPI_Status st;
    if (MPI_Improbe(MPI_ANY_SOURCE, kTag, MPI_COMM_WORLD, &found, &msg, &st) != MPI_SUCCESS) found = 0;  // (a lost peer)
    if (!found) {
      b.idle();
      continue;
    }
    b.reset();
    int count = 0;
    MPI_Get_count(&st, MPI_BYTE, &count);
    Buffer buf(static_cast<std::size_t>(count));
    MPI_Request req;
    const int source = st.MPI_SOURCE;
    receiving_since_ = clock();
    receiving_ = source;
    const bool got = MPI_Imrecv(buf.data(), count, MPI_BYTE, &msg, &req) == MPI_SUCCESS &&
                     wait(req, [&] { return stop_ || dead_[static_cast<std::size_t>(source)]; });
    receiving_ = -1;
    if (!got) continue;  // (its sender was lost meanwhile)
    heard_[static_cast<std::size_t>(source)] = clock();
    try {
      handler_(source, std::move(buf));
    } catch (const std::exception& e) {  // a malformed message: said, and the rank goes on
      std::fprintf(stderr, "rayline: rank %d: message from rank %d: %s\n", rank(), source, e.what());
    }
  }
}

std::vector<double> Comm::ping(int peer, std::size_t bytes, int n) {
  Buffer buf(bytes, 1);
  std::vector<double> out;
  for (int i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    MPI_Request req;
    check(MPI_Isend(buf.data(), int(bytes), MPI_BYTE, peer, kPingTag, MPI_COMM_WORLD, &req), "MPI_Isend");
    wait(req);
    check(MPI_Irecv(buf.data(), int(bytes), MPI_BYTE, peer, kPingTag, MPI_COMM_WORLD, &req), "MPI_Irecv");
    wait(req);
    out.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return out;
}

void Comm::echo(int peer, std::size_t bytes, int n) {
  Buffer buf(bytes);
  for (int i = 0; i < n; ++i) {
    MPI_Request req;
    check(MPI_Irecv(buf.data(), int(bytes), MPI_BYTE, peer, kPingTag, MPI_COMM_WORLD, &req), "MPI_Irecv");
    wait(req);
    check(MPI_Isend(buf.data(), int(bytes), MPI_BYTE, peer, kPingTag, MPI_COMM_WORLD, &req), "MPI_Isend");
    wait(req);
  }
}

std::vector<double> Comm::gather(const std::vector<double>& mine) {
  std::vector<double> all(rank() == 0 ? mine.size() * std::size_t(size()) : 0);
  check(MPI_Gather(mine.data(), int(mine.size()), MPI_DOUBLE, all.data(), int(mine.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD),
        "MPI_Gather");
  return all;
}

void Comm::barrier() { check(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier"); }

}  // namespace rayline::mpi
