// A block's BVH for the GPU: Embree's BVH builder (rtcNewBVH + rtcBuildBVH, the idea of
// Embree's "bvh_builder" tutorial) with our own node and leaf callbacks, then one
// depth-first pass into the flat layout of gpu_bvh.hpp. Embree's builders are a well-kept,
// parallel (TBB) SAH/Morton/SBVH implementation: we only supply the memory layout.
#include "render/vulkan/gpu_bvh.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <new>
#include <string>

namespace rayline::gpu::bvh {

static_assert(std::endian::native == std::endian::little, "block records are little-endian and copied as is");

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// One Embree device per build-thread count, for the whole process (devices are
// thread-safe; builds on them may run concurrently).
RTCDevice embree_device(int threads) {
  static std::mutex m;
  static std::map<int, RTCDevice> devices;
  std::lock_guard lk(m);
  auto it = devices.find(threads);
  if (it != devices.end()) return it->second;
  const std::string cfg = "threads=" + std::to_string(std::max(threads, 0)) + ",set_affinity=0";
  RTCDevice d = rtcNewDevice(cfg.c_str());
  if (!d)
    throw GpuError(GpuErrorKind::Failed,
                   "Embree: rtcNewDevice failed (error " + std::to_string(rtcGetDeviceError(nullptr)) + ")");
  devices.emplace(threads, d);
  return d;
}

// Widens [lo, hi] by about 8 ulps of its largest coordinate (plus a tiny absolute pad), so
// rounding in the box test and in the split clipping never culls a hit triangle.
void set_box(Child& c, const float lo[3], const float hi[3]) {
  for (int k = 0; k < 3; ++k) {
    const float m = std::max(std::fabs(lo[k]), std::fabs(hi[k]));
    const float pad = m * 0x1p-20f + 1e-30f;
    c.lo[k] = lo[k] - pad;
    c.hi[k] = hi[k] + pad;
  }
}

void copy_tri(const unsigned char* records, std::uint32_t prim, Tri& t) {
  const unsigned char* r = records + std::size_t(prim) * 40;
  std::memcpy(t.v0, r, 12);
  std::memcpy(t.v1, r + 12, 12);
  std::memcpy(t.v2, r + 24, 12);
  std::memcpy(&t.material, r + 36, 4);
  t.prim = prim;
  t.pad = 0;
}

// The callbacks write the final layout directly, in parallel on Embree's build threads:
// createNode takes the next node index, createLeaf the next run of triangle slots (and
// copies the triangles there), setNodeChildren / setNodeBounds fill the node's two child
// slots. No tree of pointers and no flattening pass (it cost more than the build itself).
// Embree treats the returned node pointers as opaque; ours are tagged integers:
// ((index + 1) << 1) for an inner node, (leaf word << 1) | 1 for a leaf.
struct Build {
  const unsigned char* records = nullptr;
  Node* nodes = nullptr;
  Tri* tris = nullptr;
  std::uint8_t* height = nullptr;  // per inner node: levels of inner nodes below and itself
  std::size_t node_capacity = 0, tri_capacity = 0;
  std::atomic<std::uint32_t> next_node{0}, next_tri{0};
  std::atomic<bool> overflow{false};
};

void* inner_ptr(std::uint32_t idx) { return reinterpret_cast<void*>((std::uintptr_t(idx) + 1) << 1); }
void* leaf_ptr(std::uint32_t word) { return reinterpret_cast<void*>((std::uintptr_t(word) << 1) | 1); }
bool ptr_is_leaf(const void* p) { return reinterpret_cast<std::uintptr_t>(p) & 1; }
std::uint32_t ptr_word(const void* p) {  // a child word: node index or leaf word
  const auto v = reinterpret_cast<std::uintptr_t>(p);
  return static_cast<std::uint32_t>(v & 1 ? v >> 1 : (v >> 1) - 1);
}

void* create_node(RTCThreadLocalAllocator /*alloc*/, unsigned int /*child_count*/, void* user) {
  auto* b = static_cast<Build*>(user);
  std::uint32_t idx = b->next_node.fetch_add(1, std::memory_order_relaxed);
  if (idx >= b->node_capacity) {  // cannot happen (a binary tree has fewer inner nodes than leaves)
    b->overflow = true;
    idx = 0;
  }
  b->nodes[idx] = Node{};
  b->height[idx] = 1;
  return inner_ptr(idx);
}

void set_children(void* node, void** children, unsigned int count, void* user) {
  auto* b = static_cast<Build*>(user);
  const std::uint32_t idx = ptr_word(node);
  Node& n = b->nodes[idx];
  std::uint8_t h = 0;
  for (unsigned k = 0; k < 2; ++k) {
    Child& c = n.c[k];
    if (k >= count || !children[k]) {  // a missing child: an empty leaf
      c.word = leaf_word(0, 0), c.count = 0;
    } else if (ptr_is_leaf(children[k])) {
      c.word = ptr_word(children[k]), c.count = leaf_count(c.word);
    } else {
      c.word = ptr_word(children[k]), c.count = 0;
      h = std::max(h, b->height[c.word]);  // children are complete before their parent
    }
  }
  b->height[idx] = static_cast<std::uint8_t>(h + 1);
}

void set_bounds(void* node, const RTCBounds** bounds, unsigned int count, void* user) {
  auto* b = static_cast<Build*>(user);
  Node& n = b->nodes[ptr_word(node)];
  for (unsigned k = 0; k < 2; ++k) {
    const RTCBounds& r = *bounds[k < count ? k : 0];  // a missing child gets its sibling's box
    const float lo[3] = {r.lower_x, r.lower_y, r.lower_z}, hi[3] = {r.upper_x, r.upper_y, r.upper_z};
    set_box(n.c[k], lo, hi);
  }
}

void* create_leaf(RTCThreadLocalAllocator /*alloc*/, const RTCBuildPrimitive* prims, size_t count, void* user) {
  auto* b = static_cast<Build*>(user);
  // maxLeafSize = kMaxLeafTriangles; Embree splits larger sets itself (large-leaf handling).
  const auto n = static_cast<std::uint32_t>(std::min<size_t>(count, kMaxLeafTriangles));
  std::uint32_t first = b->next_tri.fetch_add(n, std::memory_order_relaxed);
  if (first + n > b->tri_capacity) {
    b->overflow = true;
    first = 0;
  }
  for (std::uint32_t i = 0; i < n; ++i) copy_tri(b->records, prims[i].primID, b->tris[first + i]);
  return leaf_ptr(leaf_word(first, n));
}

void load_vertices(const unsigned char* records, std::uint32_t prim, float v[9]) {
  std::memcpy(v, records + std::size_t(prim) * 40, 36);
}

// Spatial split (High quality): the bounds of the parts of triangle `prim->primID` on
// either side of the plane x[dim] = pos, clipped to the reference's current bounds.
void split_primitive(const RTCBuildPrimitive* prim, unsigned int dim, float pos, RTCBounds* lb, RTCBounds* rb,
                     void* user) {
  float v[9];
  load_vertices(static_cast<Build*>(user)->records, prim->primID, v);
  float llo[3] = {INFINITY, INFINITY, INFINITY}, lhi[3] = {-INFINITY, -INFINITY, -INFINITY};
  float rlo[3] = {INFINITY, INFINITY, INFINITY}, rhi[3] = {-INFINITY, -INFINITY, -INFINITY};
  auto add = [](float* lo, float* hi, const float* p) {
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
  };
  for (int e = 0; e < 3; ++e) {
    const float* a = v + 3 * e;
    const float* b = v + 3 * ((e + 1) % 3);
    if (a[dim] <= pos) add(llo, lhi, a);
    if (a[dim] >= pos) add(rlo, rhi, a);
    if ((a[dim] < pos && b[dim] > pos) || (a[dim] > pos && b[dim] < pos)) {
      const float f = (pos - a[dim]) / (b[dim] - a[dim]);
      float p[3];
      for (int k = 0; k < 3; ++k) p[k] = a[k] + f * (b[k] - a[k]);
      p[dim] = pos;
      add(llo, lhi, p);
      add(rlo, rhi, p);
    }
  }
  const float plo[3] = {prim->lower_x, prim->lower_y, prim->lower_z};
  const float phi[3] = {prim->upper_x, prim->upper_y, prim->upper_z};
  float o[12];
  for (int k = 0; k < 3; ++k) {
    o[k] = std::max(llo[k], plo[k]), o[3 + k] = std::min(lhi[k], phi[k]);
    o[6 + k] = std::max(rlo[k], plo[k]), o[9 + k] = std::min(rhi[k], phi[k]);
  }
  o[3 + dim] = std::min(o[3 + dim], pos);  // left ends at the plane, right starts there
  o[6 + dim] = std::max(o[6 + dim], pos);
  *lb = RTCBounds{o[0], o[1], o[2], 0, o[3], o[4], o[5], 0};
  *rb = RTCBounds{o[6], o[7], o[8], 0, o[9], o[10], o[11], 0};
}

}  // namespace

struct BuildScratch::Impl {
  std::vector<RTCBuildPrimitive> prims;
  std::vector<std::uint8_t> height;
};
BuildScratch::BuildScratch() : impl(std::make_unique<Impl>()) {}
BuildScratch::~BuildScratch() = default;
std::uint64_t BuildScratch::bytes() const {
  return impl->prims.capacity() * sizeof(RTCBuildPrimitive) + impl->height.capacity();
}
std::uint64_t capacity_bytes(const FlatBvh& b) {
  return b.nodes.capacity() * sizeof(Node) + b.tris.capacity() * sizeof(Tri);
}

FlatBvh build(std::span<const unsigned char> records, std::uint64_t n, const GpuBuildOptions& opt) {
  FlatBvh out;
  BuildScratch scratch;
  build(records, n, opt, out, scratch);
  return out;
}

void build(std::span<const unsigned char> records, std::uint64_t n, const GpuBuildOptions& opt, FlatBvh& out,
           BuildScratch& scratch) {
  const auto t0 = Clock::now();
  out.nodes.clear();
  out.tris.clear();
  out.root = 0, out.depth = 0, out.seconds = 0, out.embree_seconds = 0;
  if (records.size() < n * 40) throw std::logic_error("block payload shorter than its triangles");
  if (n > kMaxBlockTriangles)
    throw GpuError(GpuErrorKind::OutOfMemory, "GPU: a block of " + std::to_string(n) + " triangles exceeds the " +
                                                  std::to_string(kMaxBlockTriangles) + " a GPU block can hold");
  // Build primitives: one per triangle with finite vertices (Embree drops the others too).
  const bool high = opt.quality == GpuBvhQuality::High;
  std::vector<RTCBuildPrimitive>& prims = scratch.impl->prims;
  prims.resize(high ? n + n / 2 + 16 : n);  // spatial splits need room for new references
  std::size_t count = 0;
  for (std::uint64_t i = 0; i < n; ++i) {
    float v[9];
    load_vertices(records.data(), static_cast<std::uint32_t>(i), v);
    bool finite = true;
    for (float x : v) finite = finite && std::isfinite(x);
    if (!finite) continue;
    RTCBuildPrimitive& p = prims[count++];
    p.lower_x = std::min({v[0], v[3], v[6]}), p.upper_x = std::max({v[0], v[3], v[6]});
    p.lower_y = std::min({v[1], v[4], v[7]}), p.upper_y = std::max({v[1], v[4], v[7]});
    p.lower_z = std::min({v[2], v[5], v[8]}), p.upper_z = std::max({v[2], v[5], v[8]});
    p.geomID = 0;
    p.primID = static_cast<unsigned>(i);
  }
  if (count == 0) {
    out.seconds = since(t0);
    return;
  }

  // Final arrays, sized for the worst case (a binary tree over r references has r - 1
  // inner nodes, + 1 for a root that is a leaf), then trimmed.
  const std::size_t refs = prims.size();
  out.nodes.resize(refs);
  out.tris.resize(refs);
  std::vector<std::uint8_t>& height = scratch.impl->height;
  height.resize(refs);
  Build ctx;
  ctx.records = records.data();
  ctx.nodes = out.nodes.data();
  ctx.tris = out.tris.data();
  ctx.height = height.data();
  ctx.node_capacity = refs;
  ctx.tri_capacity = refs;

  RTCDevice dev = embree_device(opt.threads);
  RTCBVH bvh = rtcNewBVH(dev);
  if (!bvh) throw GpuError(GpuErrorKind::Failed, "Embree: rtcNewBVH failed");
  RTCBuildArguments a = rtcDefaultBuildArguments();
  a.byteSize = sizeof(a);
  a.buildQuality = opt.quality == GpuBvhQuality::Low    ? RTC_BUILD_QUALITY_LOW
                   : opt.quality == GpuBvhQuality::High ? RTC_BUILD_QUALITY_HIGH
                                                        : RTC_BUILD_QUALITY_MEDIUM;
  a.buildFlags = RTC_BUILD_FLAG_NONE;
  a.maxBranchingFactor = 2;
  a.maxDepth = kMaxDepth;  // Embree fails the build rather than exceed it: the stack holds it
  a.sahBlockSize = 1;
  // The Morton builder (Low) splits down to minLeafSize regardless of cost: let it stop
  // at full leaves; the SAH builders choose leaf sizes by cost.
  a.minLeafSize = opt.quality == GpuBvhQuality::Low ? kMaxLeafTriangles : 1;
  a.maxLeafSize = kMaxLeafTriangles;
  // SAH costs of GPU BVH tracing (Karras & Aila 2013, Sec. 6: Ct = 1.2, Ci = 1): a 64-byte
  // node (two box tests) costs a little more than a 48-byte triangle test.
  a.traversalCost = 1.2f;
  a.intersectionCost = 1.0f;
  a.bvh = bvh;
  a.primitives = prims.data();
  a.primitiveCount = count;
  a.primitiveArrayCapacity = prims.size();
  a.createNode = create_node;
  a.setNodeChildren = set_children;
  a.setNodeBounds = set_bounds;
  a.createLeaf = create_leaf;
  a.splitPrimitive = high ? split_primitive : nullptr;
  a.buildProgress = nullptr;
  a.userPtr = &ctx;
  const auto te = Clock::now();
  void* root = rtcBuildBVH(&a);
  out.embree_seconds = since(te);
  const RTCError err = rtcGetDeviceError(dev);
  rtcReleaseBVH(bvh);
  if (!root || err != RTC_ERROR_NONE || ctx.overflow) {
    if (err == RTC_ERROR_OUT_OF_MEMORY)
      throw GpuError(GpuErrorKind::OutOfMemory, "Embree: rtcBuildBVH ran out of host memory");
    throw GpuError(GpuErrorKind::Failed, "Embree: rtcBuildBVH failed (error " + std::to_string(int(err)) +
                                             (ctx.overflow ? ", node or triangle capacity exceeded)" : ")"));
  }
  std::uint32_t nodes = ctx.next_node.load();
  if (ptr_is_leaf(root)) {
    // A few triangles: an inner root holding the leaf and an empty leaf.
    const std::uint32_t word = ptr_word(root);
    Node& n = out.nodes[nodes];
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (std::uint32_t i = 0; i < leaf_count(word); ++i) {
      const Tri& t = out.tris[leaf_first(word) + i];
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min({lo[k], t.v0[k], t.v1[k], t.v2[k]});
        hi[k] = std::max({hi[k], t.v0[k], t.v1[k], t.v2[k]});
      }
    }
    set_box(n.c[0], lo, hi);
    set_box(n.c[1], lo, hi);
    n.c[0].word = word, n.c[0].count = leaf_count(word);
    n.c[1].word = leaf_word(0, 0), n.c[1].count = 0;
    out.root = nodes++;
    out.depth = 1;
  } else {
    out.root = ptr_word(root);
    out.depth = height[out.root];
  }
  out.nodes.resize(nodes);
  out.tris.resize(ctx.next_tri.load());
  out.seconds = since(t0);
}

// ---- CPU mirror of shaders/traverse.comp: keep the two in step ----

namespace {

constexpr float kTinyDir = 1e-20f;   // |d| below this is replaced by +-kTinyDir for 1/d
constexpr float kErr = 0x1p-19f;     // margins of the doubtful-ray test (traverse.comp's derivation)
constexpr float kCull = 0x1p-8f;     // culling slack beyond the farthest t that matters
constexpr float kInf = INFINITY;

struct RayState {
  float o[3], d[3], inv[3], oinv[3], tmin, tmax;
};

RayState setup(const GpuRay& r) {
  RayState s{};
  for (int k = 0; k < 3; ++k) {
    s.o[k] = r.org[k], s.d[k] = r.dir[k];
    const float ds = std::fabs(r.dir[k]) < kTinyDir ? std::copysign(kTinyDir, r.dir[k]) : r.dir[k];
    s.inv[k] = 1.0f / ds;
    s.oinv[k] = s.o[k] * s.inv[k];
  }
  s.tmin = r.tmin, s.tmax = r.tmax;
  return s;
}

bool box(const RayState& s, const Child& c, float tmin_c, float tcull, float& tnear) {
  float tn[3], tf[3];
  for (int k = 0; k < 3; ++k) {
    const float t0 = std::fma(c.lo[k], s.inv[k], -s.oinv[k]), t1 = std::fma(c.hi[k], s.inv[k], -s.oinv[k]);
    tn[k] = std::min(t0, t1), tf[k] = std::max(t0, t1);
  }
  const float n = std::max(std::max(tn[0], tn[1]), std::max(tn[2], tmin_c));
  float f = std::min(std::min(tf[0], tf[1]), std::min(tf[2], tcull));
  f = f + std::fabs(f) * kCull;
  tnear = n;
  return n <= f;
}

float flip(float x, std::uint32_t sgn) { return std::bit_cast<float>(std::bit_cast<std::uint32_t>(x) ^ sgn); }

// Möller-Trumbore exactly as Embree 3 computes it on AVX2 (e1 = v0 - v1, e2 = v2 - v0,
// Ng = e2 x e1, R = C x D; its cross and dot as fused multiply-adds), with traverse.comp's
// classification: 0 certain miss, 1 doubtful, 2 certain hit (see candidate() there).
float cross_x(float ay, float az, float by, float bz) { return std::fma(ay, bz, -(az * by)); }
float dot3(const float* a, const float* b) { return std::fma(a[0], b[0], std::fma(a[1], b[1], a[2] * b[2])); }
float dot_abs(const float* a, const float* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

int candidate(const RayState& s, const Tri& tri, float tmin, float tmax, float& t, float& e, bool& plain) {
  float e1[3], e2[3], c[3], a1[3], a2[3], ac[3], ad[3];
  for (int k = 0; k < 3; ++k) {
    e1[k] = tri.v0[k] - tri.v1[k], e2[k] = tri.v2[k] - tri.v0[k], c[k] = tri.v0[k] - s.o[k];
    a1[k] = std::fabs(e1[k]), a2[k] = std::fabs(e2[k]), ac[k] = std::fabs(c[k]), ad[k] = std::fabs(s.d[k]);
  }
  const float ng[3] = {cross_x(e2[1], e2[2], e1[1], e1[2]), cross_x(e2[2], e2[0], e1[2], e1[0]),
                       cross_x(e2[0], e2[1], e1[0], e1[1])};
  const float r[3] = {cross_x(c[1], c[2], s.d[1], s.d[2]), cross_x(c[2], c[0], s.d[2], s.d[0]),
                      cross_x(c[0], c[1], s.d[0], s.d[1])};
  const float den = dot3(ng, s.d);
  const float uu = dot3(r, e2), vv = dot3(r, e1), tt = dot3(ng, c);
  const float absden = std::fabs(den);
  const std::uint32_t sgn = std::bit_cast<std::uint32_t>(den) & 0x80000000u;
  const float u = flip(uu, sgn), v = flip(vv, sgn), w = u + v;
  plain = den != 0.0f && u >= 0.0f && v >= 0.0f && w <= absden;
  t = flip(tt, sgn) / absden;
  e = kInf;
  const float ang[3] = {a2[1] * a1[2] + a2[2] * a1[1], a2[2] * a1[0] + a2[0] * a1[2], a2[0] * a1[1] + a2[1] * a1[0]};
  const float ar[3] = {ac[1] * ad[2] + ac[2] * ad[1], ac[2] * ad[0] + ac[0] * ad[2], ac[0] * ad[1] + ac[1] * ad[0]};
  const float mden = kErr * dot_abs(ang, ad), mu = kErr * dot_abs(ar, a2), mv = kErr * dot_abs(ar, a1);
  const float mw = mden + mu + mv;
  if (!(absden > mden)) {
    if ((uu > mu && vv < -mv) || (uu < -mu && vv > mv) || std::fabs(uu + vv) - absden > mw) return 0;
    t = 0;
    return 1;
  }
  if (u < -mu || v < -mv || w - absden > mw) return 0;
  e = (kErr * dot_abs(ang, ac) + std::fabs(t) * mden) / (absden - mden) + kErr * std::fabs(t);
  if (!(e < kInf)) {
    t = 0, e = kInf;
    return 1;
  }
  if (t + e < tmin || t - e > tmax) return 0;
  return (u > mu && v > mv && absden - w > mw && t - e > tmin && t + e < tmax) ? 2 : 1;
}

float triangle(const RayState& s, const Tri& tri) {
  float t = 0, e = 0;
  bool plain = false;
  candidate(s, tri, s.tmin, s.tmax, t, e, plain);
  return plain ? t : NAN;
}

// Returns the closest hit (t's sign bit: doubtful) or, for Any, the any-hit code in prim.
template <bool Any>
GpuHit traverse(const FlatBvh& b, const GpuRay& r) {
  GpuHit h{};
  h.t = INFINITY, h.prim = kNoHit, h.material = kNoHit;
  if (b.nodes.empty()) {
    if (Any) h.prim = 0;
    return h;
  }
  const RayState s = setup(r);
  const float tq = s.tmax, tmin_c = s.tmin - s.tmin * kCull;
  float tmax = tq, tcull = tq;
  std::uint32_t best = kNoHit, best_prim = kNoHit;
  bool best_sure = false, doubt = false, guess = false, occ = false;
  float best_lo = 0, best_hi = kInf, rival_lo = kInf;
  std::uint32_t stack[kStackSize];
  int sp = 0;
  std::uint32_t cur = b.root;
  for (;;) {
    if (!is_leaf(cur)) {
      const Node& n = b.nodes[cur];
      float na = 0, nb = 0;
      const bool ha = box(s, n.c[0], tmin_c, tcull, na), hb = box(s, n.c[1], tmin_c, tcull, nb);
      std::uint32_t ca = n.c[0].word, cb = n.c[1].word;
      if (ha && hb) {
        if (nb < na) std::swap(ca, cb);
        stack[sp++] = cb;
        cur = ca;
      } else if (ha) {
        cur = ca;
      } else if (hb) {
        cur = cb;
      } else {
        if (sp == 0) break;
        cur = stack[--sp];
      }
      continue;
    }
    const std::uint32_t first = leaf_first(cur), cnt = leaf_count(cur);
    for (std::uint32_t k = 0; k < cnt && !occ; ++k) {
      const Tri& tri = b.tris[first + k];
      float t = 0, e = 0;
      bool plain = false;
      const int cls = candidate(s, tri, s.tmin, tq, t, e, plain);
      if (cls == 0) continue;
      if (Any) {
        occ = cls == 2;
        doubt = doubt || cls == 1;
        guess = guess || (cls == 1 && plain && t >= s.tmin && t <= tq);
        continue;
      }
      if (plain && t >= s.tmin && t <= tmax && (t < tmax || tri.prim < best_prim)) {
        if (best != kNoHit) rival_lo = std::min(rival_lo, best_lo);
        tmax = t, best = first + k, best_prim = tri.prim, best_sure = cls == 2;
        best_lo = t - e, best_hi = t + e;
        const float cut = std::min(tq, best_hi);
        doubt = doubt || cut > tcull;
        tcull = cut;
      } else {
        rival_lo = std::min(rival_lo, t - e);
      }
    }
    if (occ || sp == 0) break;
    cur = stack[--sp];
  }
  if (Any) {
    h.prim = occ ? 1u : (doubt ? (guess ? 3u : 2u) : 0u);
    return h;
  }
  doubt = doubt || (best != kNoHit ? (!best_sure || rival_lo <= best_hi) : rival_lo < kInf);
  if (best != kNoHit) {
    const Tri& tri = b.tris[best];
    h.t = tmax, h.prim = tri.prim, h.material = tri.material;
    std::memcpy(h.v, tri.v0, 12);
    std::memcpy(h.v + 3, tri.v1, 12);
    std::memcpy(h.v + 6, tri.v2, 12);
  }
  if (doubt) h.t = -h.t;
  return h;
}

}  // namespace

GpuHit closest(const FlatBvh& b, const GpuRay& r) { return traverse<false>(b, r); }
float triangle_t(const Tri& t, const GpuRay& r) { return triangle(setup(r), t); }
std::uint8_t any(const FlatBvh& b, const GpuRay& r) { return static_cast<std::uint8_t>(traverse<true>(b, r).prim); }

}  // namespace rayline::gpu::bvh
