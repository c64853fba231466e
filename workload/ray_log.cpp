#include "workload/ray_log.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "common/error.hpp"

namespace rayline {

namespace {

constexpr char kMagic[8] = {'R', 'A', 'Y', 'L', 'O', 'G', '0', '1'};
constexpr std::size_t kVisitBytes = 12;

template <class T>
void put(std::ofstream& out, T v) {
  unsigned char b[sizeof(T)];
  for (std::size_t i = 0; i < sizeof(T); ++i) b[i] = static_cast<unsigned char>((static_cast<std::uint64_t>(v) >> (8 * i)) & 0xFF);
  out.write(reinterpret_cast<const char*>(b), sizeof(T));
}

class Reader {
 public:
  explicit Reader(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    if (!in_) throw InputError(path, "", std::string("cannot open ray log: ") + std::strerror(errno));
  }
  template <class T>
  T get(const char* field) {
    unsigned char b[sizeof(T)];
    if (!in_.read(reinterpret_cast<char*>(b), sizeof(T)))
      throw InputError(path_, field, "file ends early (truncated ray log)");
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) v |= std::uint64_t(b[i]) << (8 * i);
    return static_cast<T>(v);
  }
  void bytes(char* p, std::size_t n, const char* field) {
    if (!in_.read(p, static_cast<std::streamsize>(n))) throw InputError(path_, field, "file ends early (truncated ray log)");
  }
  bool at_end() { return in_.peek() == std::char_traits<char>::eof(); }
  std::uint64_t remaining() {
    const auto here = in_.tellg();
    in_.seekg(0, std::ios::end);
    const auto end = in_.tellg();
    in_.seekg(here);
    return static_cast<std::uint64_t>(end - here);
  }

 private:
  std::string path_;
  std::ifstream in_;
};

}  // namespace

void RayLog::save(const std::string& path) const {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(kMagic, sizeof kMagic);
  put<std::uint32_t>(out, width);
  put<std::uint32_t>(out, height);
  put<std::uint32_t>(out, spp);
  put<std::uint32_t>(out, cells);
  put<std::uint64_t>(out, entry.size());
  put<std::uint64_t>(out, visits.size());
  put<std::uint64_t>(out, children.size());
  for (std::uint32_t e : entry) put<std::uint32_t>(out, e);
  for (const RayVisit& v : visits) {
    put<std::uint32_t>(out, v.cell);
    put<std::uint32_t>(out, v.first);
    put<std::uint16_t>(out, v.bounce);
    put<std::uint8_t>(out, v.kind);
    put<std::uint8_t>(out, v.children);
  }
  for (std::uint32_t c : children) put<std::uint32_t>(out, c);
  out.close();
  if (!out) {
    const int err = errno;
    throw std::runtime_error("cannot write " + path + (err != 0 ? std::string(": ") + std::strerror(err) : std::string()));
  }
}

RayLog RayLog::load(const std::string& path) {
  Reader r(path);
  char magic[8];
  r.bytes(magic, sizeof magic, "header");
  if (std::memcmp(magic, kMagic, sizeof kMagic) != 0)
    throw InputError(path, "header", "not a Rayline ray log (written by rayline render --record-twin)");
  RayLog log;
  log.width = r.get<std::uint32_t>("width");
  log.height = r.get<std::uint32_t>("height");
  log.spp = r.get<std::uint32_t>("spp");
  log.cells = r.get<std::uint32_t>("cells");
  const auto n_entry = r.get<std::uint64_t>("camera rays");
  const auto n_visits = r.get<std::uint64_t>("visits");
  const auto n_children = r.get<std::uint64_t>("children");
  if (n_entry != std::uint64_t(log.width) * log.height * log.spp)
    throw InputError(path, "camera rays", std::to_string(n_entry) + " camera rays, but width x height x spp = " +
                                              std::to_string(std::uint64_t(log.width) * log.height * log.spp));
  if (n_visits >= kNoVisit || n_children >= kNoVisit) throw InputError(path, "visits", "too many visits for 32-bit ids");
  // Sizes are checked against the file before anything is allocated.
  const std::uint64_t need = 4 * n_entry + kVisitBytes * n_visits + 4 * n_children;
  if (r.remaining() != need)
    throw InputError(path, "visits", "the header promises " + std::to_string(need) + " bytes of records, the file holds " +
                                         std::to_string(r.remaining()));
  log.entry.resize(n_entry);
  for (auto& e : log.entry) {
    e = r.get<std::uint32_t>("entry");
    if (e != kNoVisit && e >= n_visits) throw InputError(path, "entry", "camera ray's first visit out of range");
  }
  log.visits.resize(n_visits);
  for (RayVisit& v : log.visits) {
    v.cell = r.get<std::uint32_t>("visits.cell");
    v.first = r.get<std::uint32_t>("visits.first");
    v.bounce = r.get<std::uint16_t>("visits.bounce");
    v.kind = r.get<std::uint8_t>("visits.kind");
    v.children = r.get<std::uint8_t>("visits.children");
    if (v.cell >= log.cells) throw InputError(path, "visits.cell", "cell " + std::to_string(v.cell) + " out of range");
    if (v.kind > 1) throw InputError(path, "visits.kind", "kind must be 0 (path) or 1 (shadow)");
    if (std::uint64_t(v.first) + v.children > n_children)
      throw InputError(path, "visits.first", "children out of range");
  }
  log.children.resize(n_children);
  for (std::size_t i = 0; i < n_children; ++i) {
    const auto c = r.get<std::uint32_t>("children");
    if (c >= n_visits) throw InputError(path, "children", "visit id out of range");
    log.children[i] = c;
  }
  // A child is recorded after its parent: ids grow along every path, so a log holds no
  // cycle (the twin's rays always end).
  for (std::size_t i = 0; i < log.visits.size(); ++i)
    for (std::uint32_t k = 0; k < log.visits[i].children; ++k)
      if (log.children[log.visits[i].first + k] <= i)
        throw InputError(path, "children", "visit " + std::to_string(i) + " hands a ray back to an earlier visit");
  return log;
}

}  // namespace rayline
