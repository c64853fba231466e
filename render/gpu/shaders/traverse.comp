#version 450
// RayIntersect / ShadowIntersect of ray batching (Son & Yoon 2017, Sec. 3.1: the E-jobs
// run on whole ray queues) against one block's BVH (Sec. 6: "each block has its own BVH").
// One invocation per ray; stack-based BVH2 traversal, near child first (Aila & Laine
// 2009's node layout: both child boxes in one 64-byte node). Compiled twice: closest hit
// (default) and any hit (-DANY_HIT). Layout and rationale: render/gpu/README.md; the CPU
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
const float kBoxEps = 1.0e-6;     // widening of a box's exit distance: conservative box test
const uint kInfBits = 0x7F800000u;  // +infinity: a miss's t
const uint kDone = 0x7FFFFFFFu;     // end of traversal (never a node index: < 2^28 nodes)

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.ray_count) return;
  const vec4 r0 = rays[2u * i];
  const vec4 r1 = rays[2u * i + 1u];
  const vec3 o = r0.xyz;
  const vec3 d = r1.xyz;
  const float tmin = r0.w;
  float tmax = r1.w;
  // Safe reciprocal: a zero component becomes +-kTinyDir (sign kept), so the slab distances
  // are finite or +-inf, never NaN, for axis-aligned rays (|o * inv| < 3.4e38 for any
  // |o| < 3.4e18, so the fma below never meets inf - inf).
  const uvec3 dsign = floatBitsToUint(d) & uvec3(kLeafBit);
  const vec3 tiny = uintBitsToFloat(floatBitsToUint(vec3(kTinyDir)) | dsign);
  const vec3 inv = 1.0 / mix(d, tiny, lessThan(abs(d), vec3(kTinyDir)));
  // Slab distances as fma(lo, inv, -o * inv) (Aila & Laine 2009): one instruction per plane.
  // The cancellation error (~|o * inv| ulps) stays inside the boxes' widening (~8 ulps of
  // their coordinates, and |o| <= |lo| + |lo - o|) and the exit slack (README).
  const vec3 oinv = o * inv;

  uint best = kNoHit;       // leaf-order index of the closest triangle
  uint best_prim = kNoHit;  // its record index (ties at equal t: the smaller wins)
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
        const float anear = max(max(an.x, an.y), max(an.z, tmin));
        float afar = min(min(af.x, af.y), min(af.z, tmax));
        const float bnear = max(max(bn.x, bn.y), max(bn.z, tmin));
        float bfar = min(min(bf.x, bf.y), min(bf.z, tmax));
        // Conservative: rounding in the slab distances (and the triangle test's t) never
        // culls a hit (cf. PBRT's 1 + 2 gamma(3) factor; boxes are widened too).
        afar = afar + abs(afar) * kBoxEps;
        bfar = bfar + abs(bfar) * kBoxEps;
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
        // Leaf: Möller-Trumbore exactly as Embree 3 computes it on AVX2 (e1 = v0 - v1,
        // e2 = v2 - v0, Ng = e2 x e1, R = C x D, with its cross (msub(a.y, b.z, a.z * b.y), ...)
        // and dot (madd(a.x, b.x, madd(a.y, b.y, a.z * b.z))) as fused multiply-adds), so the
        // edge decisions match Embree's bit for bit; `precise` keeps every fma fused and
        // stops the driver from fusing or reordering anything else.
        const uint first = (cur >> 3) & 0x0FFFFFFFu;
        const uint cnt = cur & 7u;
        for (uint k = 0u; k < cnt; ++k) {
          const uint ti = 3u * (first + k);
          const vec4 p0 = tris[ti], p1 = tris[ti + 1u], p2 = tris[ti + 2u];
          precise vec3 e1 = p0.xyz - p1.xyz;
          precise vec3 e2 = p2.xyz - p0.xyz;
          precise vec3 c = p0.xyz - o;
          precise vec3 ng = vec3(fma(e2.y, e1.z, -(e2.z * e1.y)), fma(e2.z, e1.x, -(e2.x * e1.z)),
                                 fma(e2.x, e1.y, -(e2.y * e1.x)));
          precise vec3 r = vec3(fma(c.y, d.z, -(c.z * d.y)), fma(c.z, d.x, -(c.x * d.z)), fma(c.x, d.y, -(c.y * d.x)));
          precise float den = fma(ng.x, d.x, fma(ng.y, d.y, ng.z * d.z));
          precise float uu = fma(r.x, e2.x, fma(r.y, e2.y, r.z * e2.z));
          precise float vv = fma(r.x, e1.x, fma(r.y, e1.y, r.z * e1.z));
          const float absden = abs(den);
          const uint sgn = floatBitsToUint(den) & kLeafBit;
          const float u = uintBitsToFloat(floatBitsToUint(uu) ^ sgn);
          const float v = uintBitsToFloat(floatBitsToUint(vv) ^ sgn);
          precise float w = u + v;
          if (den != 0.0 && u >= 0.0 && v >= 0.0 && w <= absden) {
            precise float tt = fma(ng.x, c.x, fma(ng.y, c.y, ng.z * c.z));
            precise float t = uintBitsToFloat(floatBitsToUint(tt) ^ sgn) / absden;
            if (t >= tmin && t <= tmax) {
#ifdef ANY_HIT
              occ = true;
              break;
#else
              const uint prim = floatBitsToUint(p0.w);
              if (t < tmax || prim < best_prim) {
                tmax = t;
                best = first + k;
                best_prim = prim;
              }
#endif
            }
          }
        }
#ifdef ANY_HIT
        if (occ) {  // early exit: any hit will do
          cur = kDone;
          break;
        }
#endif
        cur = sp == 0 ? kDone : stack_[--sp];
      }
    }
  }

#ifdef ANY_HIT
  occluded[i] = occ ? 1u : 0u;
#else
  if (best != kNoHit) {
    const uint ti = 3u * best;
    const uvec4 q0 = floatBitsToUint(tris[ti]);
    const uvec4 q1 = floatBitsToUint(tris[ti + 1u]);
    const uvec4 q2 = floatBitsToUint(tris[ti + 2u]);
    hits[3u * i] = uvec4(floatBitsToUint(tmax), q0.w, q1.w, q0.x);
    hits[3u * i + 1u] = uvec4(q0.y, q0.z, q1.x, q1.y);
    hits[3u * i + 2u] = uvec4(q1.z, q2.x, q2.y, q2.z);
  } else {
    hits[3u * i] = uvec4(kInfBits, kNoHit, kNoHit, 0u);
    hits[3u * i + 1u] = uvec4(0u);
    hits[3u * i + 2u] = uvec4(0u);
  }
#endif
}
