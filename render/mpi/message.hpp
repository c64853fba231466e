// The messages of a distributed render (render/mpi/README.md, "Protocol"): a fixed header
// and typed sections, each a count followed by trivially copyable records. Ranks run the
// same binary on the same kind of machine, so records travel as their bytes.
#pragma once
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "render/mpi/comm.hpp"

namespace rayline::mpi {

enum class Op : std::uint32_t {
  Setup,     // master -> node: the frame (scene, blocks, settings)
  Load,      // master -> node: disk->RAM T-job of a scene block
  Exec,      // master -> node: an E-job on one of its CPU threads, its queues already there
  Send,      // master -> node: send a block (scene block or ray queue) to another rank's RAM
  Data,      // node -> node: the block itself, for the receiver's RAM
  Evict,     // master -> node: drop blocks from its RAM (evictions of another rank's activity)
  Upload,    // master -> node: RAM->GPU T-job of a scene block or a ray queue on its GPU
  Done,      // node -> master: an activity ended (with an E-job's outputs)
  Stop,      // master -> node: the frame is done; reply with statistics
  Stats,     // node -> master: the reply to Stop
  Fatal,     // node -> master: the node cannot go on (message)
  Heartbeat, // node -> master, every 250 ms: still here
  Lost,      // master -> node: rank `dest` stopped answering; send it nothing more
};

struct Header {
  Op op = Op::Done;
  std::int32_t activity = -1;  // the master's ActivityId
  std::int32_t block = -1;     // the master's BlockId (a ray queue) or -1
  std::uint32_t cell = 0;      // a scene block's cell
  std::int32_t dest = -1;      // Send: the receiving rank
  std::int32_t device = -1;    // Exec: the node's local CPU thread; Data: 1 = a scene block
  std::int32_t slot = 0;       // Exec: the job's slot (kind % 2)
  std::int32_t ok = 1;         // Done: 0 = failed (the message says why)
};

// A ray queue of an E-job and its rays (RayBatchJob::parts, on the wire).
struct Part {
  std::int32_t block = -1;
  std::uint32_t rays = 0;
};

class Writer {
 public:
  explicit Writer(const Header& h) { put(&h, sizeof h); }
  template <class T>
  Writer& records(std::span<const T> v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const std::uint64_t n = v.size();
    put(&n, sizeof n);
    put(v.data(), v.size_bytes());
    return *this;
  }
  template <class T>
  Writer& records(const std::vector<T>& v) { return records(std::span<const T>(v)); }
  Writer& text(const std::string& s) { return records(std::span<const char>(s.data(), s.size())); }
  template <class T>
  Writer& value(const T& v) { return records(std::span<const T>(&v, 1)); }
  Buffer& buffer() { return b_; }

 private:
  void put(const void* p, std::size_t n) {
    if (n == 0) return;
    const std::size_t at = b_.size();
    b_.resize(at + n);
    std::memcpy(b_.data() + at, p, n);
  }
  Buffer b_;
};

class Reader {
 public:
  explicit Reader(const Buffer& b) : b_(b) { get(&h_, sizeof h_); }
  const Header& header() const { return h_; }
  template <class T>
  std::vector<T> records() {
    std::uint64_t n = 0;
    get(&n, sizeof n);
    if (n > (b_.size() - at_) / std::max<std::size_t>(sizeof(T), 1)) throw std::runtime_error("MPI message: truncated section");
    std::vector<T> v(static_cast<std::size_t>(n));
    get(v.data(), v.size() * sizeof(T));
    return v;
  }
  // A section of bytes without a copy (valid while the buffer lives).
  std::span<const unsigned char> bytes() {
    std::uint64_t n = 0;
    get(&n, sizeof n);
    if (n > b_.size() - at_) throw std::runtime_error("MPI message: truncated section");
    std::span<const unsigned char> s(b_.data() + at_, static_cast<std::size_t>(n));
    at_ += static_cast<std::size_t>(n);
    return s;
  }
  std::string text() {
    const auto s = bytes();
    return std::string(reinterpret_cast<const char*>(s.data()), s.size());
  }
  template <class T>
  T value() {
    const auto v = records<T>();
    if (v.size() != 1) throw std::runtime_error("MPI message: expected one record");
    return v[0];
  }

 private:
  void get(void* p, std::size_t n) {
    if (b_.size() - at_ < n) throw std::runtime_error("MPI message: truncated");
    if (n) std::memcpy(p, b_.data() + at_, n);
    at_ += n;
  }
  const Buffer& b_;
  Header h_;
  std::size_t at_ = 0;
};

}  // namespace rayline::mpi
