// BVH traversal and ray/primitive intersection. Rust twin: src/bvh/, whose mod.rs documents the
// node layout, the link encoding, the tie rule and the numerics. Every step below repeats the
// Rust arithmetic in the same order; intermediate values are `precise` so the compiler cannot
// fuse multiply-adds (which would change results and break the sign symmetry of the watertight
// edge functions).
//
// Include after `#version 460` and after a generated interface that declares the four bindings
// read below (bvh_nodes, bvh_prims, tri_data, sphere_data) and defines BVH_DECLARED: the
// wavefront kernels' (wavefront/interface.glsl) or a probe's (src/gpu/interface.rs `probe_glsl`,
// whose `BVH_BINDINGS` lists them). Their formats and contents: src/gpu/layout.rs `Binding`.
#ifndef BVH_GLSL
#define BVH_GLSL

#ifndef BVH_DECLARED
#error "bvh.glsl needs a generated interface (wavefront/interface.glsl or a probe's) first"
#endif

vec4 bvh_node(uint i) { return uintBitsToFloat(imageLoad(bvh_nodes, int(i))); }
uint bvh_prim(uint i) { return imageLoad(bvh_prims, int(i)).x; }
vec4 tri_texel(uint i) { return uintBitsToFloat(imageLoad(tri_data, int(i))); }
vec4 sphere_texel(uint i) { return uintBitsToFloat(imageLoad(sphere_data, int(i))); }

// Triangle i's three texels: the vertices v0, v1, v2 in .xyz, the material and emitter bits in
// v0.w and v1.w (layout: src/gpu/layout.rs `Binding::glsl`).
void triangle_texels(uint i, out vec4 v0, out vec4 v1, out vec4 v2) {
    v0 = tri_texel(3u * i);
    v1 = tri_texel(3u * i + 1u);
    v2 = tri_texel(3u * i + 2u);
}

// Sphere i's two texels: (center, radius) and (material, emitter, inward, 0) as bits.
void sphere_texels(uint i, out vec4 center_radius, out uvec4 info) {
    center_radius = sphere_texel(2u * i);
    info = floatBitsToUint(sphere_texel(2u * i + 1u));
}

struct Hit {
    float t;
    uint prim;   // primitive reference
    vec2 bary;   // (b1, b2) for triangles: p = (1-b1-b2) v0 + b1 v1 + b2 v2; zero for spheres
};

#define BVH_SPHERE_BIT 0x80000000u
#define BVH_LEAF_FLAG 0x80000000u
#define BVH_STACK_SIZE 64
// 1 + 2^-20 (Rust BOX_WIDEN), 2^-80 (ZERO_DIR), 2^120 (ZERO_INV), 2^80 (ZERO_PAD),
// 2^-18 (SPHERE_ON_SURFACE), largest finite float.
#define BVH_BOX_WIDEN uintBitsToFloat(0x3F800008u)
#define BVH_ZERO_DIR uintBitsToFloat(0x17800000u)
#define BVH_ZERO_INV uintBitsToFloat(0x7B800000u)
#define BVH_ZERO_PAD uintBitsToFloat(0x67800000u)
#define BVH_SPHERE_ON_SURFACE uintBitsToFloat(0x36800000u)
#define BVH_FLT_MAX uintBitsToFloat(0x7F7FFFFFu)

// Per-ray constants (Rust: struct Ray).
struct BvhRay {
    vec3 o;
    vec3 inv;   // safe inverse direction
    vec3 pad;   // BVH_ZERO_PAD on zero components, else 0
    int kx;     // Woop et al. shear axes, kz = largest |d| component
    int ky;
    int kz;
    vec3 s;     // (Sx, Sy, Sz)
};

float bvh_dot3(vec3 a, vec3 b) {
    precise float r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}

void bvh_safe_inv(float d, out float inv, out float pad) {
    if (abs(d) < BVH_ZERO_DIR) {
        inv = BVH_ZERO_INV;
        pad = BVH_ZERO_PAD;
    } else {
        inv = 1.0 / d;
        pad = 0.0;
    }
}

// False for a zero, infinite or NaN direction: such a ray hits nothing.
bool bvh_make_ray(vec3 o, vec3 d, out BvhRay r) {
    vec3 a = abs(d);
    int kz;
    if (a.x >= a.y && a.x >= a.z) {
        kz = 0;
    } else if (a.y >= a.z) {
        kz = 1;
    } else {
        kz = 2;
    }
    r.o = o;
    r.kz = kz;
    r.kx = 0;
    r.ky = 0;
    r.s = vec3(0.0);
    r.inv = vec3(0.0);
    r.pad = vec3(0.0);
    if (!(a[kz] > 0.0 && a[kz] <= BVH_FLT_MAX)) return false;
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0.0) {
        int tmp = kx;
        kx = ky;
        ky = tmp;
    }
    r.kx = kx;
    r.ky = ky;
    r.s = vec3(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    bvh_safe_inv(d.x, r.inv.x, r.pad.x);
    bvh_safe_inv(d.y, r.inv.y, r.pad.y);
    bvh_safe_inv(d.z, r.inv.z, r.pad.z);
    return true;
}

// Conservative slab test (Ize 2013); returns hit, writes the entry distance clamped to 0.
bool bvh_box_hit(BvhRay r, vec3 bmin, vec3 bmax, float tmax, out float tnear) {
    precise vec3 t0 = (bmin - r.o) * r.inv;
    precise vec3 t1 = (bmax - r.o) * r.inv;
    precise vec3 tn = min(t0, t1) - r.pad;
    precise vec3 tf = max(t0, t1) + r.pad;
    tnear = max(max(tn.x, tn.y), max(tn.z, 0.0));
    precise float tfar = min(min(tf.x, tf.y), min(tf.z, tmax)) * BVH_BOX_WIDEN;
    return tnear <= tfar;
}

// Woop–Benthin–Wald watertight test: t in (0, tmax] and (b1, b2); a hit at exactly tmax is
// returned, for the tie rule (bvh_traverse).
bool bvh_triangle(BvhRay r, vec3 v0, vec3 v1, vec3 v2, float tmax, out float t, out vec2 bary) {
    t = 0.0;
    bary = vec2(0.0);
    precise vec3 a = v0 - r.o;
    precise vec3 b = v1 - r.o;
    precise vec3 c = v2 - r.o;
    precise float ax = a[r.kx] - r.s.x * a[r.kz];
    precise float ay = a[r.ky] - r.s.y * a[r.kz];
    precise float bx = b[r.kx] - r.s.x * b[r.kz];
    precise float by = b[r.ky] - r.s.y * b[r.kz];
    precise float cx = c[r.kx] - r.s.x * c[r.kz];
    precise float cy = c[r.ky] - r.s.y * c[r.kz];
    precise float u = cx * by - cy * bx;
    precise float v = ax * cy - ay * cx;
    precise float w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
    precise float det = u + v + w;
    if (det == 0.0) return false;
    precise float az = r.s.z * a[r.kz];
    precise float bz = r.s.z * b[r.kz];
    precise float cz = r.s.z * c[r.kz];
    precise float tt = u * az + v * bz + w * cz;
    if ((det < 0.0 && tt >= 0.0) || (det > 0.0 && tt <= 0.0)) return false;
    precise float rcp = 1.0 / det;
    precise float th = tt * rcp;
    if (!(th > 0.0 && th <= tmax)) return false;
    t = th;
    bary = vec2(v * rcp, w * rcp);
    return true;
}

// Ray/sphere (Ray Tracing Gems ch. 7): the smallest root in (0, tmax]; an origin on the
// surface (within about 16 ulps of max(|o|, radius)) drops the root at t ≈ 0. Rust: sphere in
// src/bvh/intersect.rs.
bool bvh_sphere(vec3 o, vec3 d, vec3 center, float radius, float tmax, out float t) {
    t = 0.0;
    precise vec3 f = o - center;
    float a = bvh_dot3(d, d);
    if (!(a > 0.0)) return false;
    float b = bvh_dot3(f, d);
    precise float r2 = radius * radius;
    precise float c = bvh_dot3(f, f) - r2;
    precise float k = b / a;
    precise vec3 l = f - d * k;
    precise float disc = a * (r2 - bvh_dot3(l, l));
    if (disc < 0.0) return false;
    float sq = sqrt(disc);
    precise float q = b >= 0.0 ? -b - sq : -b + sq;
    if (q == 0.0) return false;
    float m = max(max(abs(o.x), abs(o.y)), max(abs(o.z), abs(radius)));
    precise float tol = abs(radius) * m * BVH_SPHERE_ON_SURFACE;
    bool on_surface = abs(c) <= tol;
    precise float t0 = on_surface ? 0.0 : c / q;
    precise float t1 = q / a;
    float lo = t0 <= t1 ? t0 : t1;
    float hi = t0 <= t1 ? t1 : t0;
    if (lo > 0.0 && lo <= tmax) {
        t = lo;
        return true;
    }
    if (hi > 0.0 && hi <= tmax) {
        t = hi;
        return true;
    }
    return false;
}

// Stack entry of a child link (Rust: fn link).
uint bvh_link(uint index, uint count) {
    return count == 0u ? index : (BVH_LEAF_FLAG | (index << 3) | (count - 1u));
}

// The primitive kinds a scene has: the renderer defines BVH_TRIANGLES and/or BVH_SPHERES (both
// when neither is defined). On lavapipe both sides of a branch run whatever the lanes decide,
// so code for a kind the scene lacks would cost every primitive test.
#if !defined(BVH_TRIANGLES) && !defined(BVH_SPHERES)
#define BVH_TRIANGLES
#define BVH_SPHERES
#endif

// Ray against primitive reference `ref`: t in (0, tmax] and (b1, b2) for triangles.
bool bvh_primitive(BvhRay r, vec3 o, vec3 d, uint ref, float tmax, out float t, out vec2 bary) {
    bary = vec2(0.0);
#if defined(BVH_SPHERES) && defined(BVH_TRIANGLES)
    if ((ref & BVH_SPHERE_BIT) != 0u) {
        vec4 cr = sphere_texel((ref & ~BVH_SPHERE_BIT) * 2u);
        return bvh_sphere(o, d, cr.xyz, cr.w, tmax, t);
    }
    uint k = ref * 3u;
    return bvh_triangle(r, tri_texel(k).xyz, tri_texel(k + 1u).xyz, tri_texel(k + 2u).xyz, tmax, t, bary);
#elif defined(BVH_SPHERES)
    vec4 cr = sphere_texel((ref & ~BVH_SPHERE_BIT) * 2u);
    return bvh_sphere(o, d, cr.xyz, cr.w, tmax, t);
#else
    uint k = ref * 3u;
    return bvh_triangle(r, tri_texel(k).xyz, tri_texel(k + 1u).xyz, tri_texel(k + 2u).xyz, tmax, t, bary);
#endif
}

// The traversal stack. With BVH_STACK_REGS defined (the host does when the tree is shallow
// enough: src/bvh/node.rs `register_stack_size`), its entries are that many variables with
// constant indices, which the compiler keeps in registers, top at st[0]: a push shifts every
// entry down, a pop up, as selects. Otherwise it is an array indexed by the stack pointer, in
// memory: on lavapipe every store to it is a per-lane loop that branches on each lane's mask
// (mispredicted on divergent rays) and every load a per-lane gather, which cost the register
// stack's shifts several times over (BENCHMARKS.md). Either way the stack holds the same entries
// in the same order, so the traversal visits the same nodes.
#ifdef BVH_STACK_REGS
#define BVH_STACK_CAPACITY BVH_STACK_REGS
// Push `far` if `push`, else pop if `pop` (the caller has read the top). Loops of constant trip
// count: unrolled, so every index is a constant.
#define BVH_STACK_STEP(st, sp, push, pop, far)                                                  \
    for (int k_ = BVH_STACK_REGS - 1; k_ > 0; --k_) st[k_] = (push) ? st[k_ - 1] : st[k_];      \
    st[0] = (push) ? (far) : st[0];                                                           \
    for (int k_ = 0; k_ < BVH_STACK_REGS - 1; ++k_) st[k_] = (pop) ? st[k_ + 1] : st[k_];
#define BVH_STACK_TOP(st, sp) st[0]
#else
#define BVH_STACK_CAPACITY BVH_STACK_SIZE
#define BVH_STACK_STEP(st, sp, push, pop, far) \
    if (push) st[sp] = (far);
#define BVH_STACK_TOP(st, sp) st[(sp) == 0u ? 0u : (sp) - 1u]
#endif

// Near-first stack traversal of the binary tree. The CPU reference walks a 4-wide tree
// collapsed from it (src/bvh/traverse.rs), in another order; both keep the same hit, because
// the tie rule (among equal t the smallest primitive reference) does not depend on the order.
// any_hit stops at the first hit. Inner nodes are walked in a loop of their own until
// the ray reaches a leaf ("while-while", Aila & Laine 2009): on a SIMD machine the lanes that
// reached a leaf wait there, and the costly leaf code runs once for all of them. The stack
// cannot overflow: the builder bounds the depth below BVH_STACK_SIZE, and the host defines
// BVH_STACK_REGS only above the tree's depth + 1 (src/bvh/node.rs).
bool bvh_traverse(vec3 o, vec3 d, float tmax, bool any_hit, out Hit hit) {
    hit.t = tmax;
    hit.prim = 0xFFFFFFFFu;
    hit.bary = vec2(0.0);
    BvhRay r;
    if (!bvh_make_ray(o, d, r)) return false;
    bool found = false;
    uint stack[BVH_STACK_CAPACITY];
#ifdef BVH_STACK_REGS
    // Defined values for the shifts to move (unrolled: constant indices).
    for (int i = 0; i < BVH_STACK_REGS; ++i) stack[i] = 0u;
#endif
    uint sp = 0u;
    uint cur = 0u;
    while (true) {
        bool live = true;
        while ((cur & BVH_LEAF_FLAG) == 0u) {
            uint base = cur * 4u;
            vec4 n0 = bvh_node(base);
            vec4 n1 = bvh_node(base + 1u);
            vec4 n2 = bvh_node(base + 2u);
            vec4 n3 = bvh_node(base + 3u);
            uint left = floatBitsToUint(n0.w);
            uint right = floatBitsToUint(n1.w);
            uint left_count = floatBitsToUint(n2.w);
            uint right_count = floatBitsToUint(n3.w);
            float tl;
            float tr;
            bool hl = bvh_box_hit(r, n0.xyz, n1.xyz, hit.t, tl);
            bool hr = bvh_box_hit(r, n2.xyz, n3.xyz, hit.t, tr);
            hl = hl && (left_count != 0u || left != 0u);
            hr = hr && (right_count != 0u || right != 0u);
            uint cl = bvh_link(left, left_count);
            uint cr = bvh_link(right, right_count);
            bool swap = tr < tl;
            bool both = hl && hr;
            bool pop = !hl && !hr;
            if (pop && sp == 0u) {
                live = false;
                break;
            }
            // Both children: the near one next, the far one pushed. Neither: pop. The top is
            // read at every step, before the step moves it: reading it only for a pop (inside
            // the ternary) made the array stack's traversal about 17 % slower on lavapipe (the
            // 1M-triangle scene, paired CPU seconds; BENCHMARKS.md), the register stack's no
            // faster.
            bool push = both && sp < uint(BVH_STACK_CAPACITY);
            uint top = BVH_STACK_TOP(stack, sp);
            BVH_STACK_STEP(stack, sp, push, pop, swap ? cl : cr)
            sp = push ? sp + 1u : (pop ? sp - 1u : sp);
            cur = both ? (swap ? cr : cl) : (hl ? cl : (hr ? cr : top));
        }
        if (!live) break;
        uint first = (cur >> 3) & 0x0FFFFFFFu;
        uint end = first + (cur & 7u) + 1u;
        for (uint i = first; i < end; ++i) {
            uint ref = bvh_prim(i);
            float t;
            vec2 bary;
            // The tie rule: a smaller t, or the same t and a smaller reference. Before the
            // first hit, hit.t is tmax and only t < tmax counts.
            if (bvh_primitive(r, o, d, ref, hit.t, t, bary) && (t < hit.t || (found && ref < hit.prim))) {
                hit.t = t;
                hit.prim = ref;
                hit.bary = bary;
                found = true;
                if (any_hit) return true;
            }
        }
        if (sp == 0u) break;
        cur = BVH_STACK_TOP(stack, sp);
        BVH_STACK_STEP(stack, sp, false, true, 0u)
        sp -= 1u;
    }
    return found;
}

// Closest hit with t in (0, tmax). On a miss, hit.t = tmax and hit.prim = 0xFFFFFFFF.
bool trace_closest(vec3 o, vec3 d, float tmax, out Hit hit) {
    return bvh_traverse(o, d, tmax, false, hit);
}

// Whether anything is hit with t in (0, tmax).
bool trace_any(vec3 o, vec3 d, float tmax) {
    Hit h;
    return bvh_traverse(o, d, tmax, true, h);
}

#endif
