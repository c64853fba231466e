// The ranks of a distributed render and the messages between them (render/mpi/README.md):
// the only file that sees MPI. Every rank runs one receiver thread, which matches each
// arriving message (MPI_Improbe + MPI_Mrecv) and hands it to the handler; any thread may
// send. Idle waits poll with short sleeps rather than MPI's busy waits, so ranks sharing
// cores (`mpirun --oversubscribe`) leave them to the compute threads.
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace rayline::mpi {

using Buffer = std::vector<unsigned char>;

// MPI_Init_thread (MPI_THREAD_MULTIPLE) on construction, MPI_Finalize on destruction.
// Throws std::runtime_error when the library cannot give threaded access.
class Session {
 public:
  Session();
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }
  // Ranks sharing this rank's machine (they share its cores).
  int local_size() const { return local_size_; }
  std::string host() const;
  // Ends every rank at once (a rank whose peer failed): MPI_Abort.
  [[noreturn]] static void abort(int code);
  // A peer was lost: the process ends without MPI_Finalize.
  void peer_lost() const { peer_lost_ = true; }

 private:
  int rank_ = 0, size_ = 1, local_size_ = 1;
  mutable std::atomic<bool> peer_lost_{false};
};

// Counters of what one rank sent (README, "Messages").
struct Traffic {
  std::atomic<std::uint64_t> messages{0}, bytes{0};
};

class Comm {
 public:
  using Handler = std::function<void(int source, Buffer message)>;
  explicit Comm(const Session& s)
      : session_(s), sent_(static_cast<std::size_t>(s.size())), heard_(static_cast<std::size_t>(s.size())),
        dead_(static_cast<std::size_t>(s.size())) {}
  ~Comm() { stop(); }
  Comm(const Comm&) = delete;
  Comm& operator=(const Comm&) = delete;

  int rank() const { return session_.rank(); }
  int size() const { return session_.size(); }
  // Starts the receiver thread: `h` runs on it for every message, in arrival order per source.
  void start(Handler h);
  // Stops it (after the messages already received); idempotent.
  void stop();
  // Thread-safe; returns once the buffer may be reused (the message is on its way). Throws
  // std::runtime_error for a rank marked lost (also when it is marked while waiting).
  void send(int dest, const Buffer& message);
  // A rank that stopped answering (`mpirun --enable-recovery` keeps the others running):
  // nothing more is sent to it, and sends waiting for it give up.
  void mark_lost(int rank) {
    dead_[static_cast<std::size_t>(rank)] = true;
    session_.peer_lost();
  }
  bool lost(int rank) const { return dead_[static_cast<std::size_t>(rank)]; }
  // Seconds since the last message from `rank` arrived (since start() before any). While the
  // receiver waits for one message (a large one, or one from a rank that died mid-send), the
  // others are not heard either: their silence counts from when that wait began.
  double silent_for(int rank) const;
  // Sends whether or not `dest` is marked lost, giving up after `seconds` (a last word).
  void send_anyway(int dest, const Buffer& message, double seconds);
  // Sent so far to `dest`.
  const Traffic& sent_to(int dest) const { return sent_[static_cast<std::size_t>(dest)]; }
  // Round trips to `peer` for `bytes`-byte messages, `n` times, while the receiver thread is
  // not running (calibration, startup): the seconds of each, as measured here. The peer must
  // call echo(0, bytes, n) meanwhile.
  std::vector<double> ping(int peer, std::size_t bytes, int n);
  void echo(int peer, std::size_t bytes, int n);
  // Collectives, while the receiver thread is not running: every rank's `mine` (the same
  // length everywhere) concatenated in rank order, on rank 0 (empty elsewhere).
  std::vector<double> gather(const std::vector<double>& mine);
  void barrier();

 private:
  void receive_loop();
  const Session& session_;
  std::vector<Traffic> sent_;
  std::vector<std::atomic<double>> heard_;  // steady-clock seconds of the last message per source
  std::vector<std::atomic<bool>> dead_;
  std::atomic<int> receiving_{-1};        // the source the receiver is waiting on, or -1
  std::atomic<double> receiving_since_{0};
  Handler handler_;
  std::atomic<bool> stop_{false};
  std::thread receiver_;
};

}  // namespace rayline::mpi
