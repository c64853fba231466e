// The path-tracing workload (Sec. 3.1, 5, 6) on a scene profile: N clients request frames
// along a camera path; the jobs of Fig. 3 (path_trace_graph.hpp) appear as rays spawn rays;
// a RayFlowModel (analytic | markov | replay) says where each batch's rays go; optional job
// prediction (Sec. 5.2, JobPredictor) adds the likely next jobs early so GMB can prefetch.
// Scene blocks: a full copy on every disk (Sec. 6.1).
//
// Conservation (tests/sched/test_path_trace_conservation.cpp): rays created (primary +
// secondary + shadow) = rays ended (hit + escaped + occluded + lit), and every delivered
// frame has exactly spp samples per pixel (samples summed over the partial framebuffers
// that AdditiveCompose brings to the client = spp x pixels: per tile under replay, for the
// frame otherwise, since the Markov and analytic counts carry no tile; path_trace_clients.hpp).
#pragma once
#include <functional>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

#include "sched/core/device_graph.hpp"
#include "workload/job_predictor.hpp"
#include "workload/path_trace_clients.hpp"
#include "workload/path_trace_graph.hpp"
#include "workload/path_trace_model.hpp"
#include "workload/warm_start.hpp"
#include "sched/runtime/workload.hpp"

namespace rayline {

struct PathTraceOptions {
  int clients = 1;
  int prediction_depth = 0;    // 0: no prediction
  Fidelity fidelity = Fidelity::Markov;
  std::shared_ptr<ReplayLog> replay;  // required for Fidelity::Replay
  ReplayLog* record = nullptr;        // when set, every split is recorded (a replay log)
  int frames_per_client = 0;          // 0: frame after frame until the run ends
  int frames_in_flight = 1;           // frames each client keeps requested at once (offered load)
  Time stop_new_frames = kNever;      // no new frame requests after this time
  MemId client_memory = kNone;        // default: the platform's "clients", else its first host memory
  std::uint64_t seed = 1;
  // Rays arriving where a planned (not yet started) job holds a queue of the same kind and
  // block join it, so that E-job runs longer than planned (see add_queue). Off: they
  // wait in the global queue for a new job (Sec. 5.1 read strictly: merge into *queued* jobs).
  bool merge_planned = true;
  // ... and the planned E-job is re-timed for its grown queue (Schedule::retime), so the
  // timelines GMB plans on stay true. Off: it runs longer than planned, unannounced.
  bool retime_merged = true;
  // A planned prediction that failed is withdrawn with its T-jobs (Sec. 5.2, Schedule::
  // cancel_job). Off: it runs empty (0 s) and its prefetches still move their blocks.
  bool cancel_failed = true;
  // Per job type (JobTypeId): the most queue bytes one ray job (RayIntersect,
  // ShadowIntersect, Shade) holds: a queue stops taking merges there, and a larger one is
  // split into jobs of at most this size. 0 or absent: no cap but merge_cap (a policy's
  // device-sized jobs, scheduler_factory.hpp job_caps).
  std::vector<Bytes> job_bytes_cap;
  // Warm start (warm_start.hpp): memories begin holding the blocks used most.
  bool warm = false;
  WarmStart warm_start;
};

struct RayTally {
  std::uint64_t primary = 0, secondary = 0, shadow = 0;         // created
  std::uint64_t hit = 0, escaped = 0, occluded = 0, lit = 0;    // ended
  // Lost with a failed memory device (docs/faults.md): rays and hit records in lost queues,
  // and the primary rays of lost GenerateRays waves. created() == ended() + lost + alive.
  std::uint64_t lost = 0;
  std::uint64_t created() const { return primary + secondary + shadow; }
  std::uint64_t ended() const { return hit + escaped + occluded + lit; }
};

// Rays a job processed, and when it ran.
struct RaySpan {
  Time start = 0, end = 0;
  std::uint64_t rays = 0;
  // The rays that fall in [from, to), pro rata to the part of [start, end] inside it (a job
  // of no duration: all of them, if it ended inside).
  double within(Time from, Time to) const;
};

struct FrameReport {
  int client = 0, index = 0;
  Time requested = 0, delivered = 0;
  bool exact = false;  // every tile got exactly spp x its pixels samples
  // Abandoned: part of its work was lost with a failed device (docs/faults.md); the
  // client asked for the frame again at `delivered` (nothing was delivered).
  bool abandoned = false;
};

class PathTraceWorkload final : public Workload {
 public:
  PathTraceWorkload(const DeviceGraph& g, const SceneProfile& profile, PathTraceOptions opt);
  void start(Time now, JobPool& pool, Schedule& schedule) override;
  void on_job_finished(JobId job, Time now, JobPool& pool, Schedule& schedule) override;
  void on_idle(Time now, JobPool& pool, Schedule& schedule) override;
  bool finished() const override;
  void on_requeued(Time now, const std::vector<JobId>& jobs, JobPool& pool, Schedule& schedule) override;
  // Frame-level recovery: each frame with work in a lost job is abandoned (its remaining
  // rays drain, its samples are never composed) and its client asks for it again.
  void on_lost(Time now, const std::vector<JobId>& jobs, const std::vector<BlockId>& blocks, JobPool& pool,
               Schedule& schedule) override;

  // Actual / planned E-job duration (SimExecutor::exec_factor): a job's queue may have grown
  // by merges after it was planned, and a predicted job runs for its real rays (0: none).
  double exec_scale(JobId job, DeviceId device, const Activity& planned) const;
  Time exec_time_now(JobId job, DeviceId device) const;

  const RayTally& tally() const { return tally_; }
  std::uint64_t rays_alive() const;
  const std::vector<FrameReport>& frames() const { return reports_; }  // delivered
  // Frames abandoned after a fault (on_lost), each asked for again.
  const std::vector<FrameReport>& abandoned_frames() const { return abandoned_; }
  const PredictionStats* prediction() const { return predictor_ ? &predictor_->stats() : nullptr; }
  const RayFlowModel& model() const { return model_; }
  // Where the clients keep their framebuffers (a host memory device, pinned there for the
  // run) and how many bytes they take in all.
  MemId client_memory() const { return opt_.client_memory; }
  Bytes client_framebuffer_bytes() const;
  std::uint64_t merges() const { return merges_; }
  std::uint64_t merges_into_planned() const { return merges_planned_; }
  // What withdrawing failed predictions removed from the plan (and the T-jobs it kept
  // because another job uses their copies).
  const Schedule::CancelCount& withdrawn() const { return withdrawn_; }
  std::uint64_t jobs_of(PtJob k) const { return jobs_by_kind_[static_cast<int>(k)]; }
  // Rays of every finished RayIntersect/ShadowIntersect (block visits), and rays ended, per
  // job with the interval the job ran (a steady-state window counts the share of each job
  // that ran inside it: sim/simulation.cpp).
  const std::vector<RaySpan>& traced() const { return traced_; }
  const std::vector<RaySpan>& ended_series() const { return ended_; }
  // Rays created (primary by GenerateRays, shadow + secondary by Shade), per job, when the
  // job that created them ended: with ended_series, the growth of the rays alive.
  const std::vector<RaySpan>& created_series() const { return created_; }
  // Per job: the rays it processed (for replay checks), by JobId; 0 for non-ray jobs.
  std::uint64_t job_rays(JobId j) const;
  // Camera rays made where they enter the scene (Scheduler::ray_origin, Rayline's rule 8):
  // `origin(wave, scene block)` names the node that should make a wave's rays entering that
  // block (kNone: no preference). Set before start(). Each wave's entry split is then drawn
  // when the wave is requested, and the wave becomes one GenerateRays job per node named,
  // each with that Job::node_hint and only the rays it was given (the wave's background
  // rays, which enter no block, go with its first job). Unset: one job per wave that draws
  // the split when it ends, as in the paper.
  void set_ray_origin(std::function<NodeId(std::uint64_t wave, BlockId entry)> origin) { ray_origin_ = std::move(origin); }

 private:
  struct JobInfo {
    PtJob kind = PtJob::Generate;
    int block = -1;
    MemId mem = kNone;          // where its queue was put (merge key)
    RayCounts rays;             // rays / hit records / primary samples; Accumulate: samples per (frame, tile)
    RayCounts records;          // Accumulate: records per frame (key(frame, 0, 0))
    std::uint32_t frame = 0;    // Generate, Compose
    bool resolved = true;       // predicted jobs: false until their parent ended
    // Finished: the counts above are released (a long run finishes ~10^5 jobs) and only
    // their total is kept (rays, or records for Accumulate), for job_rays/exec_time_now.
    bool finished = false;
    std::uint64_t processed = 0;
  };
  struct Dest {
    PtJob kind;
    int block;
    RayCounts rays;
  };
  JobInfo& info(JobId j);
  Bytes bytes_per(PtJob k) const;
  BlockId new_queue(PtJob kind, int block, Bytes bytes, bool placeholder, JobPool& pool);
  Job make_job(PtJob kind, int block, BlockId queue, std::uint64_t work, Time now) const;
  void add_queue(PtJob kind, int block, MemId mem, RayCounts rays, RayCounts records, Time now, JobPool& pool, Schedule& s);
  void route(JobId parent, Dest& d, MemId mem, Time now, JobPool& pool, Schedule& s);
  void request_frame(int client, Time now, int index = -1);  // -1: the client's next frame
  void top_up(Time now, JobPool& pool, Schedule& s);
  // One GenerateRays job of frame `uid` for `rays` (per key), at the client's memory.
  JobId add_generate(std::uint32_t uid, RayCounts rays, NodeId hint, Time now, JobPool& pool, Schedule& s);
  void split_wave(std::uint32_t uid, const RayCounts& wave, Time now, JobPool& pool, Schedule& s);
  void check_frames(Time now, JobPool& pool, Schedule& s);
  void scan_planned(const Schedule& s, const JobPool& pool);
  void sample_records(RayCounts& recs, RayCounts& samples, std::uint32_t frame, int tile, std::uint64_t completed,
                      std::uint64_t contributions);
  SplitContext context(RayStage stage, std::uint64_t key, int block) const;
  // Counts carry their tile only where outcomes depend on it (replay, and a recording made
  // for replay; path_trace_clients.hpp).
  bool per_tile() const { return opt_.fidelity == Fidelity::Replay || opt_.record != nullptr; }

  const DeviceGraph& g_;
  const SceneProfile& p_;
  PathTraceOptions opt_;
  RayFlowModel model_;
  std::unique_ptr<JobPredictor> predictor_;
  std::array<JobTypeId, kPtJobCount> type_{};
  // Per kind: the largest memory device a compute device running it works from. A queued
  // job takes merged queues only while they fit there next to its scene block.
  std::array<Bytes, kPtJobCount> room_{};
  Bytes merge_cap(PtJob kind, int block) const;
  // The most rays (records) one ray job of `kind` holds under opt_.job_bytes_cap (no cap:
  // the largest count).
  std::uint64_t capped_rays(PtJob kind) const;
  std::vector<BlockId> scene_;
  std::vector<ClientState> clients_;
  std::vector<FrameState> frames_;
  std::vector<JobInfo> info_;
  // (kind, block, memory) -> a dense slot: looked up for every queue a job routes. block is
  // -1 for the kinds that have none (Accumulate).
  std::size_t queue_slot(int kind, int block, MemId mem) const {
    return (static_cast<std::size_t>(kind) * (p_.blocks.size() + 1) + static_cast<std::size_t>(block + 1)) * g_.memories.size() +
           static_cast<std::size_t>(mem);
  }
  std::vector<JobId> open_;        // slot -> queued job holding a queue there, or kNone
  std::vector<JobId> planned_at_;  // slot -> latest job planned to run there, or kNone
  std::size_t act_cursor_ = 0;
  std::uint64_t merges_planned_ = 0;
  Schedule::CancelCount withdrawn_;
  RayTally tally_;
  std::vector<FrameReport> reports_, abandoned_;
  std::vector<RaySpan> traced_, ended_, created_;
  std::array<std::uint64_t, kPtJobCount> jobs_by_kind_{};
  std::uint64_t merges_ = 0;
  Time now_ = 0;
  JobPool* pool_ = nullptr;  // for exec_scale
  std::vector<std::uint64_t> scratch_;
  std::vector<RayCounts*> dest_cache_;  // on_job_finished: its destinations, by slot
  std::vector<Dest> dests_;             // on_job_finished: the destinations themselves
  // set_ray_origin(): the hook, the waves split so far, and each part job's drawn split.
  std::function<NodeId(std::uint64_t, BlockId)> ray_origin_;
  std::uint64_t waves_ = 0;
  struct EntryPart {
    std::vector<std::tuple<int, std::uint64_t, std::uint64_t>> entry;  // (block, key, rays) in key order
    RayCounts background;                                              // rays that enter no block
  };
  std::unordered_map<JobId, EntryPart> entry_parts_;
};

}  // namespace rayline
