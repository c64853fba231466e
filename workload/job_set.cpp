#include "workload/job_set.hpp"

#include <algorithm>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>

#include "common/error.hpp"
#include "common/input_file.hpp"
#include "common/units.hpp"

namespace rayline {

using nlohmann::json;

namespace {

void check_keys(const json& obj, const std::set<std::string>& allowed, const std::string& file, const std::string& field) {
  if (!obj.is_object()) throw InputError(file, field, "expected an object");
  for (auto it = obj.begin(); it != obj.end(); ++it)
    if (!allowed.count(it.key())) throw InputError(file, field + "." + it.key(), "unknown key");
}

const json& need(const json& obj, const char* key, const std::string& file, const std::string& field) {
  auto it = obj.find(key);
  if (it == obj.end()) throw InputError(file, field + "." + key, "missing");
  return *it;
}

std::string need_string(const json& obj, const char* key, const std::string& file, const std::string& field) {
  const json& v = need(obj, key, file, field);
  if (!v.is_string()) throw InputError(file, field + "." + key, "expected a string");
  return v.get<std::string>();
}

std::vector<std::string> string_list(const json& obj, const char* key, const std::string& file, const std::string& field) {
  std::vector<std::string> out;
  auto it = obj.find(key);
  if (it == obj.end()) return out;
  if (!it->is_array()) throw InputError(file, field + "." + key, "expected an array of names");
  for (std::size_t i = 0; i < it->size(); ++i) {
    if (!(*it)[i].is_string()) throw InputError(file, field + "." + key + "[" + std::to_string(i) + "]", "expected a string");
    out.push_back((*it)[i].get<std::string>());
  }
  return out;
}

}  // namespace

JobSet parse_job_set(const std::string& text, const std::string& file, const DeviceGraph& g) {
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(file, "", std::string("invalid JSON: ") + e.what());
  }
  check_keys(root, {"name", "description", "blocks", "jobs"}, file, "$");
  JobSet set;
  std::map<std::string, BlockId> blocks;
  const json& jb = need(root, "blocks", file, "$");
  if (!jb.is_array()) throw InputError(file, "blocks", "expected an array");
  for (std::size_t i = 0; i < jb.size(); ++i) {
    const std::string f = "blocks[" + std::to_string(i) + "]";
    check_keys(jb[i], {"name", "kind", "size", "at", "scene_block"}, file, f);
    DataBlock b;
    b.name = need_string(jb[i], "name", file, f);
    if (blocks.count(b.name)) throw InputError(file, f + ".name", "duplicate block name '" + b.name + "'");
    const std::string kind = need_string(jb[i], "kind", file, f);
    if (!parse_data_kind(kind, b.kind)) throw InputError(file, f + ".kind", "unknown data kind '" + kind + "'");
    try {
      const double bytes = units::parse_bytes(need_string(jb[i], "size", file, f));
      b.bytes = static_cast<Bytes>(bytes);
    } catch (const std::invalid_argument& e) {
      throw InputError(file, f + ".size", e.what());
    }
    b.consumed = is_consumed_by_use(b.kind);
    const BlockId id = set.pool.add_block(b);
    blocks[b.name] = id;
    std::set<MemId> at;
    for (const std::string& m : string_list(jb[i], "at", file, f)) {
      const MemId mem = g.find_memory(m);
      if (mem == kNone) throw InputError(file, f + ".at", "unknown memory device '" + m + "' (not in " + g.source_file + ")");
      if (!at.insert(mem).second) throw InputError(file, f + ".at", "memory device '" + m + "' listed twice");
      if (g.memories[mem].capacity < b.bytes) throw InputError(file, f + ".size", "larger than memory device '" + m + "'");
      set.initial.emplace_back(id, mem);
    }
  }
  for (std::size_t i = 0; i < jb.size(); ++i)
    if (jb[i].contains("scene_block")) {
      const std::string f = "blocks[" + std::to_string(i) + "].scene_block";
      if (!jb[i]["scene_block"].is_string()) throw InputError(file, f, "expected a block name");
      auto it = blocks.find(jb[i]["scene_block"].get<std::string>());
      if (it == blocks.end()) throw InputError(file, f, "unknown block");
      set.pool.block(static_cast<BlockId>(i)).scene_block = it->second;
    }
  const json& jj = need(root, "jobs", file, "$");
  if (!jj.is_array()) throw InputError(file, "jobs", "expected an array");
  std::map<std::string, JobId> jobs;
  std::vector<std::vector<std::string>> after_names;
  std::set<BlockId> produced;
  std::map<BlockId, std::size_t> consumer;  // consumed-by-use blocks: the job reading each
  std::vector<Job> parsed;
  for (std::size_t i = 0; i < jj.size(); ++i) {
    const std::string f = "jobs[" + std::to_string(i) + "]";
    check_keys(jj[i], {"name", "type", "inputs", "outputs", "after", "created", "work"}, file, f);
    Job j;
    j.name = need_string(jj[i], "name", file, f);
    if (jobs.count(j.name)) throw InputError(file, f + ".name", "duplicate job name '" + j.name + "'");
    const std::string type = need_string(jj[i], "type", file, f);
    j.type = g.job_type(type);
    if (j.type == kNone) throw InputError(file, f + ".type", "unknown job type '" + type + "'");
    bool runnable = false;
    for (std::size_t d = 0; d < g.computes.size(); ++d) runnable = runnable || g.timing.supports(static_cast<DeviceId>(d), j.type);
    if (!runnable) throw InputError(file, f + ".type", "no compute device of the platform runs '" + type + "'");
    for (const std::string& n : string_list(jj[i], "inputs", file, f)) {
      auto it = blocks.find(n);
      if (it == blocks.end()) throw InputError(file, f + ".inputs", "unknown block '" + n + "'");
      if (std::find(j.inputs.begin(), j.inputs.end(), it->second) != j.inputs.end())
        throw InputError(file, f + ".inputs", "block '" + n + "' listed twice");
      // A ray queue is consumed by the job that reads it (Sec. 5.1): a second reader could
      // never run.
      if (set.pool.block(it->second).consumed) {
        auto [reader, fresh] = consumer.emplace(it->second, i);
        if (!fresh)
          throw InputError(file, f + ".inputs", "block '" + n + "' (" + std::string(to_string(set.pool.block(it->second).kind)) +
                                                    ") is consumed by use and already read by jobs[" +
                                                    std::to_string(reader->second) + "]");
      }
      j.inputs.push_back(it->second);
    }
    for (const std::string& n : string_list(jj[i], "outputs", file, f)) {
      auto it = blocks.find(n);
      if (it == blocks.end()) throw InputError(file, f + ".outputs", "unknown block '" + n + "'");
      if (std::find(j.outputs.begin(), j.outputs.end(), it->second) != j.outputs.end())
        throw InputError(file, f + ".outputs", "block '" + n + "' listed twice");
      for (auto [b, m] : set.initial)
        if (b == it->second) throw InputError(file, f + ".outputs", "block '" + n + "' is placed initially and produced by a job");
      if (!produced.insert(it->second).second) throw InputError(file, f + ".outputs", "block '" + n + "' is produced by two jobs");
      j.outputs.push_back(it->second);
    }
    if (jj[i].contains("created")) {
      try {
        if (!jj[i]["created"].is_string()) throw std::invalid_argument("expected a duration such as \"0s\"");
        j.created = units::parse_duration(jj[i]["created"].get<std::string>());
      } catch (const std::invalid_argument& e) {
        throw InputError(file, f + ".created", e.what());
      }
    }
    if (jj[i].contains("work")) {
      if (!jj[i]["work"].is_number_unsigned()) throw InputError(file, f + ".work", "expected a non-negative integer");
      j.work = jj[i]["work"].get<std::uint64_t>();
    }
    after_names.push_back(string_list(jj[i], "after", file, f));
    jobs[j.name] = static_cast<JobId>(parsed.size());
    parsed.push_back(std::move(j));
  }
  for (std::size_t i = 0; i < parsed.size(); ++i)
    for (const std::string& n : after_names[i]) {
      auto it = jobs.find(n);
      if (it == jobs.end()) throw InputError(file, "jobs[" + std::to_string(i) + "].after", "unknown job '" + n + "'");
      parsed[i].after.push_back(it->second);
    }
  // Every input must exist somewhere at some point; dependencies must be acyclic.
  std::set<BlockId> placed;
  for (auto [b, m] : set.initial) placed.insert(b);
  std::vector<std::vector<JobId>> deps(parsed.size());
  std::map<BlockId, JobId> producer;
  for (std::size_t i = 0; i < parsed.size(); ++i)
    for (BlockId o : parsed[i].outputs) producer[o] = static_cast<JobId>(i);
  for (std::size_t i = 0; i < parsed.size(); ++i) {
    for (BlockId b : parsed[i].inputs) {
      if (!placed.count(b) && !producer.count(b))
        throw InputError(file, "jobs[" + std::to_string(i) + "].inputs",
                         "block '" + set.pool.block(b).name + "' is neither placed ('at') nor produced by a job");
      if (producer.count(b)) deps[i].push_back(producer[b]);
    }
    deps[i].insert(deps[i].end(), parsed[i].after.begin(), parsed[i].after.end());
  }
  std::vector<int> mark(parsed.size(), 0);
  std::function<void(std::size_t)> visit = [&](std::size_t i) {
    if (mark[i] == 2) return;
    if (mark[i] == 1) throw InputError(file, "jobs[" + std::to_string(i) + "]", "dependency cycle through job '" + parsed[i].name + "'");
    mark[i] = 1;
    for (JobId d : deps[i]) visit(static_cast<std::size_t>(d));
    mark[i] = 2;
  };
  for (std::size_t i = 0; i < parsed.size(); ++i) visit(i);
  for (Job& j : parsed) set.pool.add_job(std::move(j));
  return set;
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
