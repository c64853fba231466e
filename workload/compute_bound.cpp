#include "workload/compute_bound.hpp"

#include <glpk.h>

#include <array>
#include <limits>
#include <map>
#include <memory>

#include "workload/path_trace_graph.hpp"

namespace rayline {

namespace {

// The three ray job types of the bound and what one record of each costs (Eq. 2's rate
// term for its queue: bytes per record x seconds per byte).
constexpr std::array<PtJob, 3> kRayJobs = {PtJob::Intersect, PtJob::Shade, PtJob::Shadow};

const std::vector<double>& work_of(const RayFlowExpectation& e, PtJob t) {
  return t == PtJob::Intersect ? e.intersect : t == PtJob::Shade ? e.shade : e.shadow;
}

// Identical compute devices (kind, memory capacity, per-record costs): one LP block.
struct DeviceClass {
  ComputeKind kind = ComputeKind::Cpu;
  Bytes capacity = 0;
  std::array<double, 3> cost{};  // seconds per record; < 0: cannot run that job type
  int count = 0;
};

std::vector<DeviceClass> device_classes(const DeviceGraph& g, const SceneProfile& p) {
  std::map<std::tuple<int, Bytes, std::array<double, 3>>, int> index;
  std::vector<DeviceClass> classes;
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const ComputeDevice& c = g.computes[d];
    DeviceClass k;
    k.kind = c.kind;
    k.capacity = c.memory >= 0 ? g.memories[static_cast<std::size_t>(c.memory)].capacity : 0;
    for (std::size_t i = 0; i < kRayJobs.size(); ++i) {
      const JobTypeId type = g.job_type(std::string(kPtJobTypeNames[static_cast<std::size_t>(kRayJobs[i])]));
      const DeviceId id = static_cast<DeviceId>(d);
      k.cost[i] = type != kNone && g.timing.supports(id, type)
                      ? static_cast<double>(pt_record_bytes(p, kRayJobs[i])) *
                            g.timing.at(id, type).rate[static_cast<std::size_t>(pt_queue_kind(kRayJobs[i]))]
                      : -1.0;
    }
    const auto key = std::make_tuple(static_cast<int>(k.kind), k.capacity, k.cost);
    auto [it, fresh] = index.emplace(key, static_cast<int>(classes.size()));
    if (fresh) classes.push_back(k);
    ++classes[static_cast<std::size_t>(it->second)].count;
  }
  return classes;
}

// One row of the program: work of one job type on a group of blocks that the same device
// classes can hold.
struct WorkItem {
  std::size_t job = 0;             // index into kRayJobs
  double work = 0;                 // records per camera ray
  std::vector<bool> holders;       // per device class: can hold every block of the group
  int example_block = -1;          // for the message when nothing can run it
};

std::vector<WorkItem> work_items(const SceneProfile& p, const RayFlowExpectation& e, const std::vector<DeviceClass>& classes) {
  std::vector<WorkItem> items;
  for (std::size_t j = 0; j < kRayJobs.size(); ++j) {
    const bool reads_scene = kRayJobs[j] != PtJob::Shade;
    std::map<std::vector<bool>, std::size_t> group;
    const std::vector<double>& w = work_of(e, kRayJobs[j]);
    for (std::size_t b = 0; b < p.blocks.size(); ++b) {
      if (w[b] <= 0) continue;
      std::vector<bool> holders(classes.size());
      for (std::size_t c = 0; c < classes.size(); ++c)
        holders[c] = !reads_scene || classes[c].capacity >= p.blocks[b].bytes;
      auto [it, fresh] = group.emplace(holders, items.size());
      if (fresh) items.push_back({j, 0.0, holders, static_cast<int>(b)});
      items[it->second].work += w[b];
    }
  }
  return items;
}

struct ProblemDeleter {
  void operator()(glp_prob* lp) const { glp_delete_prob(lp); }
};

}  // namespace

ComputeBound compute_bound(const DeviceGraph& g, const SceneProfile& p, const RayFlowExpectation& flow) {
  ComputeBound out;
  const std::vector<DeviceClass> classes = device_classes(g, p);
  const std::vector<WorkItem> items = work_items(p, flow, classes);

  // Units: millions of records per second, so coefficients stay near 1.
  constexpr double kScale = 1e6;
  std::unique_ptr<glp_prob, ProblemDeleter> lp(glp_create_prob());
  glp_set_obj_dir(lp.get(), GLP_MAX);
  glp_add_cols(lp.get(), 1);  // column 1: X
  glp_set_col_bnds(lp.get(), 1, GLP_LO, 0.0, 0.0);
  glp_set_obj_coef(lp.get(), 1, 1.0);
  const int item_rows = static_cast<int>(items.size());
  glp_add_rows(lp.get(), item_rows + static_cast<int>(classes.size()));
  std::vector<int> ia{0}, ja{0};
  std::vector<double> ar{0.0};
  auto put = [&](int row, int col, double v) {
    ia.push_back(row);
    ja.push_back(col);
    ar.push_back(v);
  };
  struct Column {
    std::size_t cls, item;
  };
  std::vector<Column> columns;
  for (int i = 0; i < item_rows; ++i) {
    const WorkItem& it = items[static_cast<std::size_t>(i)];
    glp_set_row_bnds(lp.get(), i + 1, GLP_FX, 0.0, 0.0);  // sum_d x - W X = 0
    put(i + 1, 1, -it.work);
    bool any = false;
    for (std::size_t c = 0; c < classes.size(); ++c) {
      const double cost = classes[c].cost[it.job];
      if (cost < 0 || !it.holders[c]) continue;
      if (cost == 0) {
        out.limit = "unbounded: a device runs " + std::string(kPtJobTypeNames[static_cast<std::size_t>(kRayJobs[it.job])]) +
                    " at no cost per ray (T_RATE is 0)";
        out.camera_rays_per_second = out.rays_shot_per_second = out.block_visits_per_second =
            std::numeric_limits<double>::infinity();
        return out;
      }
      const int col = glp_add_cols(lp.get(), 1);
      glp_set_col_bnds(lp.get(), col, GLP_LO, 0.0, 0.0);
      put(i + 1, col, 1.0);
      put(item_rows + 1 + static_cast<int>(c), col, cost * kScale);
      columns.push_back({c, static_cast<std::size_t>(i)});
      any = true;
    }
    if (!any) {
      out.limit = "no compute device can run " + std::string(kPtJobTypeNames[static_cast<std::size_t>(kRayJobs[it.job])]) +
                  " on block " + std::to_string(it.example_block) + " (unsupported, or its memory cannot hold the block)";
      return out;
    }
  }
  for (std::size_t c = 0; c < classes.size(); ++c)
    glp_set_row_bnds(lp.get(), item_rows + 1 + static_cast<int>(c), GLP_UP, 0.0, static_cast<double>(classes[c].count));
  glp_load_matrix(lp.get(), static_cast<int>(ia.size()) - 1, ia.data(), ja.data(), ar.data());
  glp_smcp parm;
  glp_init_smcp(&parm);
  parm.msg_lev = GLP_MSG_OFF;
  if (glp_simplex(lp.get(), &parm) != 0 || glp_get_status(lp.get()) != GLP_OPT) {
    out.limit = "the linear program has no optimum (GLPK status " + std::to_string(glp_get_status(lp.get())) + ")";
    return out;
  }
  const double x = glp_get_col_prim(lp.get(), 1) * kScale;
  out.camera_rays_per_second = x;
  out.rays_shot_per_second = x * flow.rays_shot();
  out.block_visits_per_second = x * flow.block_visits();

  // Per device kind: time used and block visits taken at the optimum.
  for (ComputeKind kind : {ComputeKind::Cpu, ComputeKind::Gpu}) {
    ComputeBound::Kind k;
    k.kind = kind == ComputeKind::Cpu ? "cpu" : "gpu";
    double used = 0;
    for (std::size_t c = 0; c < classes.size(); ++c)
      if (classes[c].kind == kind) {
        k.devices += classes[c].count;
        used += glp_get_row_prim(lp.get(), item_rows + 1 + static_cast<int>(c));
      }
    for (std::size_t i = 0; i < columns.size(); ++i) {
      const Column& col = columns[i];
      if (classes[col.cls].kind != kind || kRayJobs[items[col.item].job] == PtJob::Shade) continue;
      k.block_visits_per_second += glp_get_col_prim(lp.get(), 2 + static_cast<int>(i)) * kScale;
    }
    if (k.devices == 0) continue;
    k.busy_share = used / k.devices;
    out.kinds.push_back(k);
  }
  return out;
}

}  // namespace rayline
