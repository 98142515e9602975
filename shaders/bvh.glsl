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
#extension GL_EXT_control_flow_attributes : require

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

// Texels per sphere (Rust: scene_buffers::SPHERE_TEXELS): (center, radius), (material, emitter,
// inward, frame flags) as bits, the frame's quaternion (texture.glsl).
#define SPHERE_TEXELS 3u
// Sphere i's first two texels.
void sphere_texels(uint i, out vec4 center_radius, out uvec4 info) {
    center_radius = sphere_texel(SPHERE_TEXELS * i);
    info = floatBitsToUint(sphere_texel(SPHERE_TEXELS * i + 1u));
}

struct Hit {
    float t;
    uint prim;   // primitive reference
    vec2 bary;   // (b1, b2) for triangles: p = (1-b1-b2) v0 + b1 v1 + b2 v2; zero for spheres
};

#define BVH_SPHERE_BIT 0x80000000u
// No primitive (a ray that leaves none; Hit.prim on a miss).
#define BVH_NO_PRIM 0xFFFFFFFFu

// The triangle a ray leaves, kept in a float of the path state (the .w of beta and of the shadow
// ray's direction) as an exact value: reference + 1 below 2^24, else 0 for none (a sphere,
// BVH_NO_PRIM, a triangle from 2^24 on, which is then tested and missed). No bit pattern of a
// NaN or subnormal number, which a driver might change on the way through memory.
float bvh_leaving_code(uint prim) { return prim < 16777216u ? float(prim + 1u) : 0.0; }
uint bvh_leaving_prim(float code) { return code > 0.0 ? uint(code) - 1u : BVH_NO_PRIM; }
#define BVH_LEAF_FLAG 0x80000000u
#define BVH_STACK_SIZE 64
// 1 + 2^-20 (Rust BOX_WIDEN), 2^-80 (ZERO_DIR), 2^120 (ZERO_INV), 2^80 (ZERO_PAD), largest
// finite float, 2^-98 (SPHERE_C_ERROR, a double).
#define BVH_BOX_WIDEN uintBitsToFloat(0x3F800008u)
#define BVH_ZERO_DIR uintBitsToFloat(0x17800000u)
#define BVH_ZERO_INV uintBitsToFloat(0x7B800000u)
#define BVH_ZERO_PAD uintBitsToFloat(0x67800000u)
#define BVH_FLT_MAX uintBitsToFloat(0x7F7FFFFFu)
#define BVH_SPHERE_C_ERROR packDouble2x32(uvec2(0x0u, 0x39d00000u))
// gamma(2), gamma(3), gamma(5) (Rust: robust::gamma), for the triangle test's t error bound.
#define BVH_GAMMA2 uintBitsToFloat(0x34000001u)
#define BVH_GAMMA3 uintBitsToFloat(0x34400002u)
#define BVH_GAMMA5 uintBitsToFloat(0x34a00003u)
// The same for double (Rust: gamma64), for the double-precision test of ambiguous hits; a device
// without shaderFloat64 compiles with BVH_NO_F64 and misses those hits instead.
#define BVH_GAMMA64_2 packDouble2x32(uvec2(0x1u, 0x3cb00000u))
#define BVH_GAMMA64_3 packDouble2x32(uvec2(0x2u, 0x3cb80000u))
#define BVH_GAMMA64_5 packDouble2x32(uvec2(0x3u, 0x3cc40000u))

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
// Rust: triangle_t_error. The bound on the rounding error of the watertight test's t (Pharr,
// Jakob & Humphreys 2016, sec. 3.9.6), from the vertices relative to the origin on the permuted
// axes before the shear (ra, rb, rc), the sheared x and y, the scaled heights z, the edge
// functions and 1/det; a hit counts only beyond it.
float bvh_triangle_t_error(vec3 ra, vec3 rb, vec3 rc, vec3 x, vec3 y, vec3 z, vec3 e, float rcp) {
    vec3 ax = abs(x);
    vec3 ay = abs(y);
    vec3 az = abs(z);
    vec3 ae = abs(e);
    float max_x = max(max(ax.x, ax.y), ax.z);
    float max_y = max(max(ay.x, ay.y), ay.z);
    float max_z = max(max(az.x, az.y), az.z);
    float max_e = max(max(ae.x, ae.y), ae.z);
    vec3 rel_max = max(max(abs(ra), abs(rb)), abs(rc));
    precise float delta_x = BVH_GAMMA5 * (rel_max.x + rel_max.z);
    precise float delta_y = BVH_GAMMA5 * (rel_max.y + rel_max.z);
    precise float delta_z = BVH_GAMMA3 * max_z;
    precise float delta_e = 2.0 * (BVH_GAMMA2 * max_x * max_y + delta_y * max_x + delta_x * max_y);
    precise float bound = 3.0 * (BVH_GAMMA3 * max_e * max_z + delta_e * max_z + delta_z * max_e) * abs(rcp);
    return bound;
}
#ifndef BVH_NO_F64
// Rust: Ray::triangle_f64. The watertight test in double, for a hit whose float t is within its
// error bound of 0 (a ray leaving a surface near an edge, or the surface it leaves): the same
// steps, the same bound for double's rounding; a t still within it is missed.
bool bvh_triangle_f64(BvhRay r, vec3 d, vec3 v0, vec3 v1, vec3 v2, float tmax, out float t, out vec2 bary) {
    t = 0.0;
    bary = vec2(0.0);
    dvec3 o = dvec3(r.o[r.kx], r.o[r.ky], r.o[r.kz]);
    dvec3 dp = dvec3(d[r.kx], d[r.ky], d[r.kz]);
    precise dvec3 a = dvec3(v0[r.kx], v0[r.ky], v0[r.kz]) - o;
    precise dvec3 b = dvec3(v1[r.kx], v1[r.ky], v1[r.kz]) - o;
    precise dvec3 c = dvec3(v2[r.kx], v2[r.ky], v2[r.kz]) - o;
    precise double sx = dp.x / dp.z;
    precise double sy = dp.y / dp.z;
    precise double sz = 1.0lf / dp.z;
    precise double ax = a.x - sx * a.z;
    precise double ay = a.y - sy * a.z;
    precise double bx = b.x - sx * b.z;
    precise double by = b.y - sy * b.z;
    precise double cx = c.x - sx * c.z;
    precise double cy = c.y - sy * c.z;
    precise double u = cx * by - cy * bx;
    precise double v = ax * cy - ay * cx;
    precise double w = bx * ay - by * ax;
    if ((u < 0.0lf || v < 0.0lf || w < 0.0lf) && (u > 0.0lf || v > 0.0lf || w > 0.0lf)) return false;
    precise double det = u + v + w;
    if (det == 0.0lf) return false;
    precise double az = sz * a.z;
    precise double bz = sz * b.z;
    precise double cz = sz * c.z;
    precise double rcp = 1.0lf / det;
    precise double th = (u * az + v * bz + w * cz) * rcp;
    if (!(th <= double(tmax))) return false;
    double max_x = max(max(abs(ax), abs(bx)), abs(cx));
    double max_y = max(max(abs(ay), abs(by)), abs(cy));
    double max_z = max(max(abs(az), abs(bz)), abs(cz));
    double max_e = max(max(abs(u), abs(v)), abs(w));
    dvec3 rel_max = max(max(abs(a), abs(b)), abs(c));
    precise double delta_x = BVH_GAMMA64_5 * (rel_max.x + rel_max.z);
    precise double delta_y = BVH_GAMMA64_5 * (rel_max.y + rel_max.z);
    precise double delta_z = BVH_GAMMA64_3 * max_z;
    precise double delta_e = 2.0lf * (BVH_GAMMA64_2 * max_x * max_y + delta_y * max_x + delta_x * max_y);
    precise double bound = 3.0lf * (BVH_GAMMA64_3 * max_e * max_z + delta_e * max_z + delta_z * max_e) * abs(rcp);
    if (th <= bound) return false;
    t = max(float(th), uintBitsToFloat(1u));
    bary = vec2(float(v * rcp), float(w * rcp));
    return true;
}
#endif

// What the single-precision triangle test found: a hit, a miss, or a t within its rounding
// error of 0, which only the double-precision test can decide.
const int BVH_MISS = 0;
const int BVH_HIT = 1;
const int BVH_AMBIGUOUS = 2;

int bvh_triangle(BvhRay r, vec3 v0, vec3 v1, vec3 v2, float tmax, out float t, out vec2 bary) {
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
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return BVH_MISS;
    precise float det = u + v + w;
    if (det == 0.0) return BVH_MISS;
    precise float az = r.s.z * a[r.kz];
    precise float bz = r.s.z * b[r.kz];
    precise float cz = r.s.z * c[r.kz];
    precise float tt = u * az + v * bz + w * cz;
    precise float rcp = 1.0 / det;
    precise float th = tt * rcp;
    if (!(th <= tmax)) return BVH_MISS;
    float bound = bvh_triangle_t_error(vec3(a[r.kx], a[r.ky], a[r.kz]), vec3(b[r.kx], b[r.ky], b[r.kz]),
                                       vec3(c[r.kx], c[r.ky], c[r.kz]), vec3(ax, bx, cx), vec3(ay, by, cy),
                                       vec3(az, bz, cz), vec3(u, v, w), rcp);
    if (th > bound) {
        t = th;
        bary = vec2(v * rcp, w * rcp);
        return BVH_HIT;
    }
    // Within the bound of 0: single precision cannot tell. The traversal redoes it in double
    // after its loop (bvh_traverse), or, without doubles, misses it.
    return th < -bound ? BVH_MISS : BVH_AMBIGUOUS;
}

// Rust: sphere_c. c = |o - center|^2 - radius^2 from the ten products o_i^2, -2 o_i center_i,
// center_i^2 and -radius^2, each exact in double, summed with error-free transformations
// (Ogita, Rump & Oishi 2005, Sum2), and its error bound 2^-98 sum |terms| (the part that can
// change c's sign).
double bvh_sphere_c(vec3 o, vec3 center, float radius, out double c_err) {
    dvec3 od = dvec3(o);
    dvec3 cd = dvec3(center);
    double rd = double(radius);
    double terms[10];
    precise double t0 = od.x * od.x;
    precise double t1 = -2.0lf * od.x * cd.x;
    precise double t2 = cd.x * cd.x;
    precise double t3 = od.y * od.y;
    precise double t4 = -2.0lf * od.y * cd.y;
    precise double t5 = cd.y * cd.y;
    precise double t6 = od.z * od.z;
    precise double t7 = -2.0lf * od.z * cd.z;
    precise double t8 = cd.z * cd.z;
    precise double t9 = -(rd * rd);
    terms[0] = t0; terms[1] = t1; terms[2] = t2; terms[3] = t3; terms[4] = t4;
    terms[5] = t5; terms[6] = t6; terms[7] = t7; terms[8] = t8; terms[9] = t9;
    precise double s = 0.0lf;
    precise double e = 0.0lf;
    precise double sum_abs = 0.0lf;
    for (int i = 0; i < 10; i++) {
        precise double x = terms[i];
        precise double sum = s + x;
        precise double bb = sum - s;
        precise double err = (s - (sum - bb)) + (x - bb);
        s = sum;
        e = e + err;
        sum_abs = sum_abs + abs(x);
    }
    precise double ce = sum_abs * BVH_SPHERE_C_ERROR;
    c_err = ce;
    precise double c = s + e;
    return c;
}

// Ray/sphere, in double from the float inputs (Rust: sphere in src/bvh/intersect.rs): the
// quadratic in the form of Haines et al. 2019 (Ray Tracing Gems ch. 7), c from bvh_sphere_c;
// the smallest root in (0, tmax]; the near root c/q is dropped when |c| is within its error
// bound (the origin is on the surface as far as the test can tell).
bool bvh_sphere(vec3 o, vec3 d, vec3 center, float radius, float tmax, out float t) {
    t = 0.0;
    precise dvec3 f = dvec3(o) - dvec3(center);
    dvec3 dd = dvec3(d);
    precise double a = dd.x * dd.x + dd.y * dd.y + dd.z * dd.z;
    if (!(a > 0.0lf)) return false;
    precise double b = f.x * dd.x + f.y * dd.y + f.z * dd.z;
    precise double r2 = double(radius) * double(radius);
    double c_err;
    double c = bvh_sphere_c(o, center, radius, c_err);
    precise double k = b / a;
    precise dvec3 l = f - dd * k;
    precise double disc = a * (r2 - (l.x * l.x + l.y * l.y + l.z * l.z));
    if (!(disc >= 0.0lf)) return false;
    double sq = sqrt(disc);
    precise double q = b >= 0.0lf ? -b - sq : -b + sq;
    if (q == 0.0lf) return false;
    precise double c_over_q = c / q;
    precise double q_over_a = q / a;
    float t0 = abs(c) <= c_err ? 0.0 : float(c_over_q);
    float t1 = float(q_over_a);
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

// Triangles that the single-precision test finds ambiguous wait, up to this many per ray, for
// the double-precision test after the traversal (bvh_traverse). More within rounding of one ray
// origin takes the origin within float rounding of a vertex where five or more triangles meet;
// past four the oldest is missed, as every ambiguous triangle is without doubles.
#if defined(BVH_TRIANGLES) && !defined(BVH_NO_F64)
#define BVH_PENDING 4
#endif

// Ray against primitive reference `ref`: t in (0, tmax] and (b1, b2) for triangles; BVH_HIT,
// BVH_MISS or (triangles only) BVH_AMBIGUOUS.
int bvh_primitive(BvhRay r, vec3 o, vec3 d, uint ref, float tmax, out float t, out vec2 bary) {
    bary = vec2(0.0);
#if defined(BVH_SPHERES) && defined(BVH_TRIANGLES)
    if ((ref & BVH_SPHERE_BIT) != 0u) {
        vec4 cr = sphere_texel((ref & ~BVH_SPHERE_BIT) * SPHERE_TEXELS);
        return bvh_sphere(o, d, cr.xyz, cr.w, tmax, t) ? BVH_HIT : BVH_MISS;
    }
    uint k = ref * 3u;
    return bvh_triangle(r, tri_texel(k).xyz, tri_texel(k + 1u).xyz, tri_texel(k + 2u).xyz, tmax, t, bary);
#elif defined(BVH_SPHERES)
    vec4 cr = sphere_texel((ref & ~BVH_SPHERE_BIT) * SPHERE_TEXELS);
    return bvh_sphere(o, d, cr.xyz, cr.w, tmax, t) ? BVH_HIT : BVH_MISS;
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

// The tie rule: a hit at (t, ref) replaces the current one when it is closer, or as close with
// a smaller reference. Before the first hit, hit.t is tmax and only t < tmax counts.
bool bvh_replaces(float t, uint ref, Hit hit, bool found) {
    return t < hit.t || (found && ref < hit.prim);
}

// Near-first stack traversal of the binary tree. The CPU reference walks an 8-wide tree
// collapsed from it (src/bvh/traverse.rs), in another order; both keep the same hit, because
// the tie rule (among equal t the smallest primitive reference) does not depend on the order.
// any_hit stops at the first hit. Inner nodes are walked in a loop of their own until
// the ray reaches a leaf ("while-while", Aila & Laine 2009): on a SIMD machine the lanes that
// reached a leaf wait there, and the costly leaf code runs once for all of them. The stack
// cannot overflow: the builder bounds the depth below BVH_STACK_SIZE, and the host defines
// BVH_STACK_REGS only above the tree's depth + 1 (src/bvh/node.rs).
// `leaving` is the triangle the ray leaves (BVH_NO_PRIM for none; a sphere's reference is not
// skipped), which the traversal does not test: the ray starts off its plane on the side it goes
// to and cannot meet it again (Rust: Bvh::closest_leaving). Tested, it would be ambiguous (t
// within its error bound of 0) and go to the double test after the loop, to be missed there.
bool bvh_traverse(vec3 o, vec3 d, float tmax, bool any_hit, uint leaving, out Hit hit) {
    hit.t = tmax;
    hit.prim = 0xFFFFFFFFu;
    hit.bary = vec2(0.0);
    // A sphere (and BVH_NO_PRIM) has the high bit: no reference is skipped.
    if ((leaving & BVH_SPHERE_BIT) != 0u) leaving = BVH_NO_PRIM;
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
#ifdef BVH_PENDING
    uvec4 pending = uvec4(0u);
    uint n_pending = 0u;
#endif
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
            int res = ref == leaving ? BVH_MISS : bvh_primitive(r, o, d, ref, hit.t, t, bary);
            if (res == BVH_HIT && bvh_replaces(t, ref, hit, found)) {
                hit.t = t;
                hit.prim = ref;
                hit.bary = bary;
                found = true;
                if (any_hit) return true;
            }
#ifdef BVH_PENDING
            // Newest first; past BVH_PENDING the oldest is dropped (missed).
            bool amb = res == BVH_AMBIGUOUS;
            pending = amb ? uvec4(ref, pending.xyz) : pending;
            n_pending = amb ? min(n_pending + 1u, uint(BVH_PENDING)) : n_pending;
#endif
        }
        if (sp == 0u) break;
        cur = BVH_STACK_TOP(stack, sp);
        BVH_STACK_STEP(stack, sp, false, true, 0u)
        sp -= 1u;
    }
#ifdef BVH_PENDING
    // The ambiguous triangles in double, against the final hit under the same tie rule: the
    // closest t, then the smallest reference, is the hit whatever the order of the tests, so
    // this is the hit the CPU reference finds testing each in double where it meets it. On
    // lavapipe, which runs both sides of every branch under a mask, the double test costs once
    // per ray here (a loop runs as often as its busiest lane needs, at least once, masked),
    // where inside the leaf loop it cost once per triangle test: 14 % of the Cornell box's time
    // (docs/bench-log.md). Not unrolled: unrolled, each of its four steps would run on every ray.
    [[dont_unroll]] while (n_pending > 0u) {
        uint ref = pending.x;
        pending = pending.yzwx;
        n_pending -= 1u;
        uint tk = ref * 3u;
        float t;
        vec2 bary;
        if (bvh_triangle_f64(r, d, tri_texel(tk).xyz, tri_texel(tk + 1u).xyz, tri_texel(tk + 2u).xyz, hit.t, t, bary)
            && bvh_replaces(t, ref, hit, found)) {
            hit.t = t;
            hit.prim = ref;
            hit.bary = bary;
            found = true;
        }
    }
#endif
    return found;
}

// Closest hit with t in (0, tmax), for a ray that leaves the triangle `leaving` (BVH_NO_PRIM:
// none). On a miss, hit.t = tmax and hit.prim = 0xFFFFFFFF.
bool trace_closest_leaving(vec3 o, vec3 d, float tmax, uint leaving, out Hit hit) {
    return bvh_traverse(o, d, tmax, false, leaving, hit);
}
bool trace_closest(vec3 o, vec3 d, float tmax, out Hit hit) {
    return bvh_traverse(o, d, tmax, false, BVH_NO_PRIM, hit);
}

// Whether anything is hit with t in (0, tmax), likewise.
bool trace_any_leaving(vec3 o, vec3 d, float tmax, uint leaving) {
    Hit h;
    return bvh_traverse(o, d, tmax, true, leaving, h);
}
bool trace_any(vec3 o, vec3 d, float tmax) {
    return trace_any_leaving(o, d, tmax, BVH_NO_PRIM);
}

#endif
