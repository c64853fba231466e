// Job-set files (schema: docs/job-sets.md) -> JobPool and initial placement. Every
// problem is an InputError(file, field, message) raised through common/json_fields.hpp;
// one function per section of the format (blocks, jobs) and per cross-check.
#include "workload/job_set.hpp"

#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>

#include "common/error.hpp"
#include "common/input_file.hpp"
#include "common/json_fields.hpp"

namespace rayline {

using nlohmann::json;

namespace {

std::vector<std::string> string_list(const JsonField& object, const char* key) {
  std::vector<std::string> out;
  const auto list = object.find(key);
  if (!list) return out;
  if (!list->json().is_array()) list->fail("expected an array of names");
  for (const JsonField& name : list->elements()) out.push_back(name.string());
  return out;
}

// A list of the document's own ("blocks", "jobs"): missing is "$.blocks", as for any key of
// the document ("$"), while the list itself and its entries are "blocks", "blocks[2]".
JsonField top_list(const JsonInput& in, const JsonField& root, const char* key) {
  const JsonField list = in.field(root.at(key).json(), key);
  if (!list.json().is_array()) list.fail("expected an array");
  return list;
}

std::string job_field(std::size_t i) { return field_index("jobs", i); }

class JobSetReader {
 public:
  JobSetReader(const JsonInput& input, const DeviceGraph& g) : in_(input), g_(g) {}

  JobSet read(const JsonField& root) {
    root.only_keys({"name", "description", "blocks", "jobs"});
    const std::vector<JsonField> blocks = top_list(in_, root, "blocks").elements();
    for (const JsonField& b : blocks) block(b);
    for (std::size_t i = 0; i < blocks.size(); ++i)
      if (const auto sb = blocks[i].find("scene_block")) scene_block(*sb, static_cast<BlockId>(i));
    const std::vector<JsonField> jobs = top_list(in_, root, "jobs").elements();
    for (std::size_t i = 0; i < jobs.size(); ++i) job(jobs[i], i);
    resolve_after();
    check_inputs_exist();
    check_acyclic();
    for (Job& j : parsed_) set_.pool.add_job(std::move(j));
    return std::move(set_);
  }

 private:
  void block(const JsonField& f) {
    f.only_keys({"name", "kind", "size", "at", "scene_block"});
    DataBlock b;
    b.name = f.at("name").string();
    if (blocks_.count(b.name)) f.at("name").fail("duplicate block name '" + b.name + "'");
    const std::string kind = f.at("kind").string();
    if (!parse_data_kind(kind, b.kind)) f.at("kind").fail("unknown data kind '" + kind + "'");
    const JsonField size = f.at("size");
    b.bytes = static_cast<Bytes>(in_.quantity(size.string(), size.path(), JsonUnit::bytes));
    b.consumed = is_consumed_by_use(b.kind);
    const BlockId id = set_.pool.add_block(b);
    blocks_[b.name] = id;
    std::set<MemId> at;
    for (const std::string& m : string_list(f, "at")) {
      const MemId mem = g_.find_memory(m);
      if (mem == kNone) f.fail_at("at", "unknown memory device '" + m + "' (not in " + g_.source_file + ")");
      if (!at.insert(mem).second) f.fail_at("at", "memory device '" + m + "' listed twice");
      if (g_.memories[mem].capacity < b.bytes) size.fail("larger than memory device '" + m + "'");
      set_.initial.emplace_back(id, mem);
    }
  }

  void scene_block(const JsonField& f, BlockId of) {
    if (!f.json().is_string()) f.fail("expected a block name");
    const auto it = blocks_.find(f.json().get<std::string>());
    if (it == blocks_.end()) f.fail("unknown block");
    set_.pool.block(of).scene_block = it->second;
  }

  void job(const JsonField& f, std::size_t i) {
    f.only_keys({"name", "type", "inputs", "outputs", "after", "created", "work"});
    Job j;
    j.name = f.at("name").string();
    if (jobs_.count(j.name)) f.at("name").fail("duplicate job name '" + j.name + "'");
    job_type(f.at("type"), j);
    for (const std::string& n : string_list(f, "inputs")) input(field_key(f.path(), "inputs"), n, i, j);
    for (const std::string& n : string_list(f, "outputs")) output(field_key(f.path(), "outputs"), n, j);
    if (const auto created = f.find("created")) {
      if (!created->json().is_string()) created->fail("expected a duration such as \"0s\"");
      j.created = in_.quantity(created->string(), created->path(), JsonUnit::duration);
    }
    if (const auto work = f.find("work")) j.work = work->unsigned_integer();
    after_names_.push_back(string_list(f, "after"));
    jobs_[j.name] = static_cast<JobId>(parsed_.size());
    parsed_.push_back(std::move(j));
  }

  void job_type(const JsonField& f, Job& j) const {
    const std::string type = f.string();
    j.type = g_.job_type(type);
    if (j.type == kNone) f.fail("unknown job type '" + type + "'");
    bool runnable = false;
    for (std::size_t d = 0; d < g_.computes.size(); ++d)
      runnable = runnable || g_.timing.supports(static_cast<DeviceId>(d), j.type);
    if (!runnable) f.fail("no compute device of the platform runs '" + type + "'");
  }

  // Entries of a job's "inputs" and "outputs" are reported at the list (`list`).
  BlockId named_block(const std::string& list, const std::string& name, const std::vector<BlockId>& listed) const {
    const auto it = blocks_.find(name);
    if (it == blocks_.end()) in_.fail(list, "unknown block '" + name + "'");
    if (std::find(listed.begin(), listed.end(), it->second) != listed.end())
      in_.fail(list, "block '" + name + "' listed twice");
    return it->second;
  }

  void input(const std::string& list, const std::string& name, std::size_t job, Job& j) {
    const BlockId b = named_block(list, name, j.inputs);
    // A ray queue is consumed by the job that reads it (Sec. 5.1): a second reader could
    // never run.
    if (set_.pool.block(b).consumed) {
      const auto [reader, fresh] = consumer_.emplace(b, job);
      if (!fresh)
        in_.fail(list, "block '" + name + "' (" + std::string(to_string(set_.pool.block(b).kind)) +
                           ") is consumed by use and already read by " + job_field(reader->second));
    }
    j.inputs.push_back(b);
  }

  void output(const std::string& list, const std::string& name, Job& j) {
    const BlockId b = named_block(list, name, j.outputs);
    for (auto [placed, m] : set_.initial)
      if (placed == b) in_.fail(list, "block '" + name + "' is placed initially and produced by a job");
    if (!produced_.insert(b).second) in_.fail(list, "block '" + name + "' is produced by two jobs");
    j.outputs.push_back(b);
  }

  void resolve_after() {
    for (std::size_t i = 0; i < parsed_.size(); ++i)
      for (const std::string& n : after_names_[i]) {
        const auto it = jobs_.find(n);
        if (it == jobs_.end()) in_.fail(job_field(i) + ".after", "unknown job '" + n + "'");
        parsed_[i].after.push_back(it->second);
      }
  }

  // Every input must exist somewhere at some point.
  void check_inputs_exist() {
    std::set<BlockId> placed;
    for (auto [b, m] : set_.initial) placed.insert(b);
    std::map<BlockId, JobId> producer;
    for (std::size_t i = 0; i < parsed_.size(); ++i)
      for (BlockId o : parsed_[i].outputs) producer[o] = static_cast<JobId>(i);
    deps_.assign(parsed_.size(), {});
    for (std::size_t i = 0; i < parsed_.size(); ++i) {
      for (BlockId b : parsed_[i].inputs) {
        if (!placed.count(b) && !producer.count(b))
          in_.fail(job_field(i) + ".inputs",
                   "block '" + set_.pool.block(b).name + "' is neither placed ('at') nor produced by a job");
        if (producer.count(b)) deps_[i].push_back(producer[b]);
      }
      deps_[i].insert(deps_[i].end(), parsed_[i].after.begin(), parsed_[i].after.end());
    }
  }

  // Dependencies (producers and `after`) must be acyclic: depth-first, 1 = on the path.
  void check_acyclic() {
    mark_.assign(parsed_.size(), 0);
    for (std::size_t i = 0; i < parsed_.size(); ++i) visit(i);
  }
  void visit(std::size_t i) {
    if (mark_[i] == 2) return;
    if (mark_[i] == 1) in_.fail(job_field(i), "dependency cycle through job '" + parsed_[i].name + "'");
    mark_[i] = 1;
    for (JobId d : deps_[i]) visit(static_cast<std::size_t>(d));
    mark_[i] = 2;
  }

  const JsonInput& in_;
  const DeviceGraph& g_;
  JobSet set_;
  std::map<std::string, BlockId> blocks_;
  std::map<std::string, JobId> jobs_;
  std::vector<Job> parsed_;
  std::vector<std::vector<std::string>> after_names_;
  std::set<BlockId> produced_;
  std::map<BlockId, std::size_t> consumer_;  // consumed-by-use blocks: the job reading each
  std::vector<std::vector<JobId>> deps_;
  std::vector<int> mark_;
};

}  // namespace

JobSet parse_job_set(const std::string& text, const std::string& file, const DeviceGraph& g) {
  const JsonInput input(file);
  const json doc = input.parse(text);
  return JobSetReader(input, g).read(input.field(doc, "$"));
}

JobSet load_job_set(const std::string& path, const DeviceGraph& g) {
  std::ifstream in = open_input(path, "job-set file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_job_set(ss.str(), path, g);
}

JobSet synthetic_ray_batching(const DeviceGraph& g, int blocks, int jobs, std::uint64_t seed, Bytes scene_bytes) {
  JobSet set;
  std::mt19937_64 rng(seed);
  auto uniform = [&rng](double lo, double hi) {  // libstdc++-independent: plain 53-bit mapping
    return lo + (hi - lo) * static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0);
  };
  std::vector<MemId> disks, hosts;
  for (std::size_t m = 0; m < g.memories.size(); ++m) {
    if (g.memories[m].kind == MemoryKind::Disk) disks.push_back(static_cast<MemId>(m));
    if (g.memories[m].kind == MemoryKind::Host) hosts.push_back(static_cast<MemId>(m));
  }
  if (disks.empty() || hosts.empty()) throw InputError(g.source_file, "memory", "synthetic jobs need at least one disk and one host memory");
  const JobTypeId ri = g.job_type("RayIntersect");
  if (ri == kNone) throw InputError(g.source_file, "job_types", "synthetic jobs need job type 'RayIntersect'");
  std::vector<BlockId> scene;
  std::vector<double> cdf;
  double acc = 0;
  for (int b = 0; b < blocks; ++b) {
    DataBlock d;
    d.name = "scene" + std::to_string(b);
    d.kind = DataKind::SceneData;
    d.bytes = static_cast<Bytes>(static_cast<double>(scene_bytes) / blocks * uniform(0.9, 1.1));
    const BlockId id = set.pool.add_block(d);
    scene.push_back(id);
    for (MemId m : disks) set.initial.emplace_back(id, m);
    acc += 1.0 / (b + 1);  // Zipf popularity
    cdf.push_back(acc);
  }
  // Queues fill at most half of a host memory (the rest is for scene blocks): a queue drawn
  // for a full host goes to the next one with room, and when none has room the snapshot
  // ends with fewer jobs (a single node holds a few hundred, not the cluster's thousand).
  std::vector<Bytes> queued(g.memories.size(), 0);
  for (int j = 0; j < jobs; ++j) {
    const double u = uniform(0, acc);
    const int b = static_cast<int>(std::lower_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
    const auto rays = static_cast<Bytes>(uniform(1e4, 5e5));
    const std::size_t drawn = static_cast<std::size_t>(uniform(0, static_cast<double>(hosts.size()))) % hosts.size();
    MemId host = kNone;
    for (std::size_t k = 0; k < hosts.size() && host == kNone; ++k) {
      const MemId h = hosts[(drawn + k) % hosts.size()];
      if (queued[h] + rays * 64 <= g.memories[h].capacity / 2) host = h;
    }
    if (host == kNone) break;
    queued[host] += rays * 64;
    DataBlock q;
    q.name = "rays" + std::to_string(j);
    q.kind = DataKind::RayQueue;
    q.consumed = true;
    q.bytes = rays * 64;
    q.scene_block = scene[std::min<std::size_t>(static_cast<std::size_t>(b), scene.size() - 1)];
    const BlockId qb = set.pool.add_block(q);
    set.initial.emplace_back(qb, host);
    Job job;
    job.name = "ri" + std::to_string(j);
    job.type = ri;
    job.inputs = {q.scene_block, qb};
    job.work = rays;
    set.pool.add_job(std::move(job));
  }
  return set;
}

}  // namespace rayline
