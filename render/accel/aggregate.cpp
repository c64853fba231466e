#include "render/accel/aggregate.hpp"

#include <utility>

namespace rayline::accel {

// Continuation in the job's cell (aggregate.hpp). Each round traces the previous round's
// rays of this cell, path rays and shadow rays as two passes (each kind has its own kernel,
// as it has its own queue); rays for other cells leave through `out`, in the order the
// rounds made them. A path makes at most two rays per hit, so the rounds end within
// 2 x max_depth.
void Aggregate::intersect(const trace::TraceSettings& ts, const QueueJob& job, std::vector<trace::RayRecord>& out,
                          trace::RayCounts& counts, const PassObserver& observe) {
  if (!ts.continue_in_cell || !traces_in_place()) {
    const std::size_t first = out.size();
    pass(ts, job, out, counts);
    if (observe) observe(job.kind, job.rays, std::span<const trace::RayRecord>(out).subspan(first));
    return;
  }
  std::vector<trace::RayRecord> made, stay[2];
  pass(ts, job, made, counts);
  if (observe) observe(job.kind, job.rays, made);
  for (;;) {
    for (const trace::RayRecord& r : made) {
      if (r.cell == job.cell) stay[static_cast<int>(r.kind)].push_back(r);
      else out.push_back(r);
    }
    if (stay[0].empty() && stay[1].empty()) return;
    made.clear();
    for (const trace::RayKind kind : {trace::RayKind::Path, trace::RayKind::Shadow}) {
      std::vector<trace::RayRecord>& in = stay[static_cast<int>(kind)];
      if (in.empty()) continue;
      const std::size_t first = made.size();
      pass(ts, QueueJob{job.cell, kind, in, {}}, made, counts);
      if (observe) observe(kind, in, std::span<const trace::RayRecord>(made).subspan(first));
      in.clear();
    }
  }
}

}  // namespace rayline::accel
