#version 450
// RayIntersect / ShadowIntersect of ray batching (Son & Yoon 2017, Sec. 3.1: the E-jobs
// run on whole ray queues) against one block's BVH (Sec. 6: "each block has its own BVH").
// One invocation per ray; stack-based BVH2 traversal, near child first (Aila & Laine
// 2009's node layout: both child boxes in one 64-byte node). Compiled twice: closest hit
// (default) and any hit (-DANY_HIT). Layout and rationale: render/vulkan/README.md; the CPU
// mirror in gpu_bvh.cpp performs the same operations in the same order.
layout(local_size_x = 64) in;

// Node i = nodes[4i .. 4i+3]: (lo_a, word_a) (hi_a, count_a) (lo_b, word_b) (hi_b, count_b).
layout(std430, set = 0, binding = 0) readonly restrict buffer Nodes { vec4 nodes[]; };
// Triangle j = tris[3j .. 3j+2]: (v0, prim) (v1, material) (v2, 0), as stored in the block.
layout(std430, set = 0, binding = 1) readonly restrict buffer Tris { vec4 tris[]; };
// Ray i = rays[2i], rays[2i+1]: (org, tmin) (dir, tmax) -- GpuRay.
layout(std430, set = 0, binding = 2) readonly restrict buffer Rays { vec4 rays[]; };
#ifdef ANY_HIT
layout(std430, set = 0, binding = 3) writeonly restrict buffer Out { uint occluded[]; };
#else
// Hit i = hits[3i .. 3i+2]: GpuHit (t, prim, material, v[9]).
layout(std430, set = 0, binding = 3) writeonly restrict buffer Out { uvec4 hits[]; };
#endif

layout(push_constant) uniform Push {
  uint ray_count;   // rays in this dispatch
  uint node_count;  // 0: an empty block, every ray misses
  uint root;        // the root node (always an inner node)
} pc;

const uint kLeafBit = 0x80000000u;
const uint kNoHit = 0xFFFFFFFFu;
const int kStackSize = 64;        // >= the tree depth (gpu_bvh.hpp)
const float kTinyDir = 1e-20;     // |d| below this -> +-kTinyDir for 1/d: no 0 * inf = NaN
const uint kInfBits = 0x7F800000u;  // +infinity: a miss's t
const float kInf = 1.0 / 0.0;  // +infinity
const uint kDone = 0x7FFFFFFFu;     // end of traversal (never a node index: < 2^28 nodes)
// Doubtful rays (render/vulkan/README.md, "Doubtful rays"): the kernel answers only what it
// can decide exactly as Embree would. kErr * |terms| bounds |X_gpu - X_embree| for X =
// den, U, V, T; kCull is the culling slack beyond the farthest t that still matters.
const float kErr = 1.0 / 524288.0;  // 2^-19
const float kCull = 1.0 / 256.0;

// Möller-Trumbore exactly as Embree 3 computes it on AVX2 (e1 = v0 - v1, e2 = v2 - v0,
// Ng = e2 x e1, R = C x D, with its cross (msub(a.y, b.z, a.z * b.y), ...) and dot
// (madd(a.x, b.x, madd(a.y, b.y, a.z * b.z))) as fused multiply-adds; `precise` keeps every
// fma as written and stops the driver from fusing or reordering anything else).
// `plain`: the test itself (den != 0, U, V >= 0, U + V <= |den|), t = T / |den|.
// Returns 0 when Embree certainly rejects the triangle for [tmin, tmax], 2 when it
// certainly accepts it with t in [t - e, t + e] strictly inside (tmin, tmax), 1 otherwise
// (doubtful: an edge or den within its margin, or t within e of tmin / tmax; t = 0,
// e = inf when t itself is unknown).
//   Margins (Higham 2002, Sec. 3.1: a sum of products computed with k roundings is off by
// at most gamma_k = k u / (1 - k u) times the same sum of |products|; u = 2^-24). From exact
// floats v0, v1, v2, o, d: e1, e2, C cost one rounding each, a term of Ng or R its product
// and the difference (an unfused fma is two roundings, as on lavapipe), a dot product one
// product and two sums: terms of den (e2 e1 d) and U, V (C d e) have k <= 1+1+2+3 = 7, of T
// (e2 e1 C) k <= 8, whatever the association or fusion (Embree with FMA, lavapipe without). |X - X_exact| <= gamma_8 |terms| < 2^-21 |terms| for each
// engine, 2^-20 between the two; kErr = 2^-19 doubles that (rounding of the |terms| sums
// and of kErr * |terms| fit in it). Assumes no underflow in the products (scene scales
// above ~1e-9). A decision on X is then certain when |X| > m_X; W = |den| - (U + V) gets
// m_den + m_U + m_V (the sum's own rounding is far inside). With den's sign certain,
// |t_gpu - t_embree| <= (m_T + |t| m_den) / (|den| - m_den) + kErr |t| (Embree's rcp and
// its range test T <= |den| tmax are a few ulps, inside kErr |t|).
int candidate(const vec3 v0, const vec3 v1, const vec3 v2, const vec3 o, const vec3 d, const float tmin,
              const float tmax, out float t, out float e, out bool plain) {
  precise vec3 e1 = v0 - v1;
  precise vec3 e2 = v2 - v0;
  precise vec3 c = v0 - o;
  precise vec3 ng = vec3(fma(e2.y, e1.z, -(e2.z * e1.y)), fma(e2.z, e1.x, -(e2.x * e1.z)),
                         fma(e2.x, e1.y, -(e2.y * e1.x)));
  precise vec3 r = vec3(fma(c.y, d.z, -(c.z * d.y)), fma(c.z, d.x, -(c.x * d.z)), fma(c.x, d.y, -(c.y * d.x)));
  precise float den = fma(ng.x, d.x, fma(ng.y, d.y, ng.z * d.z));
  precise float uu = fma(r.x, e2.x, fma(r.y, e2.y, r.z * e2.z));
  precise float vv = fma(r.x, e1.x, fma(r.y, e1.y, r.z * e1.z));
  precise float tt = fma(ng.x, c.x, fma(ng.y, c.y, ng.z * c.z));
  const float absden = abs(den);
  const uint sgn = floatBitsToUint(den) & kLeafBit;
  const float u = uintBitsToFloat(floatBitsToUint(uu) ^ sgn);
  const float v = uintBitsToFloat(floatBitsToUint(vv) ^ sgn);
  precise float w = u + v;
  plain = den != 0.0 && u >= 0.0 && v >= 0.0 && w <= absden;
  precise float tp = uintBitsToFloat(floatBitsToUint(tt) ^ sgn) / absden;
  t = tp;
  e = kInf;
  const vec3 a1 = abs(e1), a2 = abs(e2), ac = abs(c), ad = abs(d);
  const vec3 ang = vec3(a2.y * a1.z + a2.z * a1.y, a2.z * a1.x + a2.x * a1.z, a2.x * a1.y + a2.y * a1.x);
  const vec3 ar = vec3(ac.y * ad.z + ac.z * ad.y, ac.z * ad.x + ac.x * ad.z, ac.x * ad.y + ac.y * ad.x);
  const float mden = kErr * dot(ang, ad), mu = kErr * dot(ar, a2), mv = kErr * dot(ar, a1);
  const float mw = mden + mu + mv;
  if (!(absden > mden)) {  // den's sign uncertain: a miss only if one for either sign
    if ((uu > mu && vv < -mv) || (uu < -mu && vv > mv) || abs(uu + vv) - absden > mw) return 0;
    t = 0.0;
    return 1;
  }
  if (u < -mu || v < -mv || w - absden > mw) return 0;
  e = (kErr * dot(ang, ac) + abs(t) * mden) / (absden - mden) + kErr * abs(t);
  if (!(e < kInf)) {
    t = 0.0;
    e = kInf;
    return 1;
  }
  if (t + e < tmin || t - e > tmax) return 0;
  return (u > mu && v > mv && absden - w > mw && t - e > tmin && t + e < tmax) ? 2 : 1;
}

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.ray_count) return;
  const vec4 r0 = rays[2u * i];
  const vec4 r1 = rays[2u * i + 1u];
  const vec3 o = r0.xyz;
  const vec3 d = r1.xyz;
  const float tmin = r0.w;  // >= 0 (the sign bit of a hit's t flags a doubtful ray)
  const float tq = r1.w;    // the query's tmax
  float tmax = tq;          // the plain closest hit so far
  // Safe reciprocal: a zero component becomes +-kTinyDir (sign kept), so the slab distances
  // are finite or +-inf, never NaN, for axis-aligned rays (|o * inv| < 3.4e38 for any
  // |o| < 3.4e18, so the fma below never meets inf - inf).
  const uvec3 dsign = floatBitsToUint(d) & uvec3(kLeafBit);
  const vec3 tiny = uintBitsToFloat(floatBitsToUint(vec3(kTinyDir)) | dsign);
  const vec3 inv = 1.0 / mix(d, tiny, lessThan(abs(d), vec3(kTinyDir)));
  // Slab distances as fma(lo, inv, -o * inv) (Aila & Laine 2009): one instruction per plane.
  // The cancellation error (~|o * inv| ulps) stays inside the boxes' widening (~8 ulps of
  // their coordinates, and |o| <= |lo| + |lo - o|) and the culling slack (README).
  const vec3 oinv = o * inv;
  // Boxes are culled outside [tmin_c, tcull (1 + kCull)]: every triangle whose t could lie
  // within its margin of the answer is visited (README, "Doubtful rays").
  const float tmin_c = tmin - tmin * kCull;
  float tcull = tq;

  uint best = kNoHit;       // leaf-order index of the plain closest triangle
  uint best_prim = kNoHit;  // its record index (ties at equal t: the smaller wins)
  bool best_sure = false;   // certainly a hit, with t in [best_lo, best_hi]
  float best_lo = 0.0, best_hi = kInf;
  float rival_lo = kInf;    // the smallest t - e of every other candidate that is not a certain miss
  bool doubt = false;       // (any hit: a candidate that is not certain)
  bool guess = false;       // (any hit: the plain test accepted one of them)
  bool occ = false;

  if (pc.node_count != 0u) {
    uint stack_[kStackSize];  // per-invocation (local memory on a GPU)
    int sp = 0;
    uint cur = pc.root;
    // "While-while" traversal (Aila & Laine 2009, Sec. 3): descend through inner nodes
    // until a leaf comes up, then test leaves until an inner node comes up, so the threads
    // of a warp run the node code and the triangle code in longer uniform stretches.
    while (cur != kDone) {
      while ((cur & kLeafBit) == 0u && cur != kDone) {
        // Both children's slab tests from one node fetch.
        const uint b = 4u * cur;
        const vec4 alo = nodes[b], ahi = nodes[b + 1u], blo = nodes[b + 2u], bhi = nodes[b + 3u];
        const vec3 a0 = fma(alo.xyz, inv, -oinv), a1 = fma(ahi.xyz, inv, -oinv);
        const vec3 b0 = fma(blo.xyz, inv, -oinv), b1 = fma(bhi.xyz, inv, -oinv);
        const vec3 an = min(a0, a1), af = max(a0, a1);
        const vec3 bn = min(b0, b1), bf = max(b0, b1);
        const float anear = max(max(an.x, an.y), max(an.z, tmin_c));
        float afar = min(min(af.x, af.y), min(af.z, tcull));
        const float bnear = max(max(bn.x, bn.y), max(bn.z, tmin_c));
        float bfar = min(min(bf.x, bf.y), min(bf.z, tcull));
        // Conservative: rounding in the slab distances never culls a box the triangle test
        // needs (cf. PBRT's 1 + 2 gamma(3) factor; boxes are widened too), and kCull keeps
        // candidates within their margin of the cut.
        afar = afar + abs(afar) * kCull;
        bfar = bfar + abs(bfar) * kCull;
        const bool ha = anear <= afar;
        const bool hb = bnear <= bfar;
        uint ca = floatBitsToUint(alo.w);
        uint cb = floatBitsToUint(blo.w);
        if (ha && hb) {
          if (bnear < anear) {
            const uint tmp = ca;
            ca = cb;
            cb = tmp;
          }
          stack_[sp++] = cb;  // far child later
          cur = ca;
        } else if (ha) {
          cur = ca;
        } else if (hb) {
          cur = cb;
        } else {
          cur = sp == 0 ? kDone : stack_[--sp];
        }
      }
      while ((cur & kLeafBit) != 0u) {
        const uint first = (cur >> 3) & 0x0FFFFFFFu;
        const uint cnt = cur & 7u;
        for (uint k = 0u; k < cnt; ++k) {
          const uint ti = 3u * (first + k);
          const vec4 p0 = tris[ti], p1 = tris[ti + 1u], p2 = tris[ti + 2u];
          float t, e;
          bool plain;
          const int cls = candidate(p0.xyz, p1.xyz, p2.xyz, o, d, tmin, tq, t, e, plain);
          if (cls == 0) continue;  // (the plain test rejects it too)
#ifdef ANY_HIT
          if (cls == 2) {  // early exit only on a certain hit
            occ = true;
            break;
          }
          doubt = true;  // search on: a certain hit may still come
          guess = guess || (plain && t >= tmin && t <= tq);
#else
          const uint prim = floatBitsToUint(p0.w);
          if (plain && t >= tmin && t <= tmax && (t < tmax || prim < best_prim)) {
            if (best != kNoHit) rival_lo = min(rival_lo, best_lo);  // the old best is a rival now
            tmax = t;
            best = first + k;
            best_prim = prim;
            best_sure = cls == 2;
            best_lo = t - e;
            best_hi = t + e;
            // Cull beyond the new best's margin; had an earlier cut been lower, something
            // within this margin may have been culled: doubtful.
            const float cut = min(tq, best_hi);
            doubt = doubt || cut > tcull;
            tcull = cut;
          } else {
            rival_lo = min(rival_lo, t - e);
          }
#endif
        }
#ifdef ANY_HIT
        if (occ) {  // early exit: a certain hit will do
          cur = kDone;
          break;
        }
#endif
        cur = sp == 0 ? kDone : stack_[--sp];
      }
    }
  }

#ifdef ANY_HIT
  // 0 unoccluded, 1 occluded (both certain); doubtful: 2 | the plain test's answer.
  occluded[i] = occ ? 1u : (doubt ? (guess ? 3u : 2u) : 0u);
#else
  // Certain: the plain best is a certain hit and every rival starts beyond its margin, or
  // there is neither best nor rival. Otherwise doubtful: the sign bit of t.
  doubt = doubt || (best != kNoHit ? (!best_sure || rival_lo <= best_hi) : rival_lo < kInf);
  const uint flag = doubt ? kLeafBit : 0u;
  if (best != kNoHit) {
    const uint ti = 3u * best;
    const uvec4 q0 = floatBitsToUint(tris[ti]);
    const uvec4 q1 = floatBitsToUint(tris[ti + 1u]);
    const uvec4 q2 = floatBitsToUint(tris[ti + 2u]);
    hits[3u * i] = uvec4(floatBitsToUint(tmax) | flag, q0.w, q1.w, q0.x);
    hits[3u * i + 1u] = uvec4(q0.y, q0.z, q1.x, q1.y);
    hits[3u * i + 2u] = uvec4(q1.z, q2.x, q2.y, q2.z);
  } else {
    hits[3u * i] = uvec4(kInfBits | flag, kNoHit, kNoHit, 0u);
    hits[3u * i + 1u] = uvec4(0u);
    hits[3u * i + 2u] = uvec4(0u);
  }
#endif
}
