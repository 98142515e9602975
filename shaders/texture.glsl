// Image textures on material parameters: the (u, v) of a surface point, the texture lookup
// (Mitsuba's bitmap conventions: texel centres, bilinear or nearest, repeat / mirror / clamp,
// to_uv) and the values written into the material record. Rust twin (independent code, the
// same conventions and arithmetic, documented there): src/texture.rs, and for the record
// src/brdf/textured.rs. Compiled in under SCENE_TEXTURES only.
// Data (src/gpu/scene_buffers.rs `TextureTable`): the textures' texels in binding `images`
// (after the environment map's); in `texture_info`, texel 0 unused, then 3 texels per texture
// (first texel, width, height, filter | wrap << 4), (to_uv row 0 as float bits, 0),
// (to_uv row 1, 0), then each textured material's list at its record's header.w: (count, 0, 0,
// 0) and per textured parameter (texture, record word, slot mode, 0).
#ifndef TEXTURE_GLSL
#define TEXTURE_GLSL
#ifdef SCENE_TEXTURES

// Slot modes (Rust: brdf::textured::SlotMode).
#define TEXTURE_SLOT_RGB 0u
#define TEXTURE_SLOT_SCALAR 1u
#define TEXTURE_SLOT_SPLAT 2u
#define TEXTURE_SLOT_ANGLE 3u
// Wrap modes (Rust: texture::Wrap) and filters (texture::Filter).
#define TEXTURE_REPEAT 0u
#define TEXTURE_MIRROR 1u
#define TEXTURE_CLAMP 2u
#define TEXTURE_NEAREST 1u

uvec4 texture_info_at(uint i) { return imageLoad(texture_info, int(i)); }

// i modulo n in [0, n), for |i| <= 2^28 + 1, in unsigned arithmetic (GLSL's % of a negative
// int is not defined): i + 2^30 is positive.
uint texture_mod(int i, uint n) {
    uint b = uint(i + 1073741824);
    return (b % n + n - 1073741824u % n) % n;
}

// Texel index i of a side of n texels under the wrap mode. Rust twin: texture::wrap_index.
uint texture_wrap(int i, uint n, uint wrap) {
    if (wrap == TEXTURE_CLAMP) return uint(clamp(i, 0, int(n) - 1));
    if (wrap == TEXTURE_MIRROR) {
        uint p = texture_mod(i, 2u * n);
        return p < n ? p : 2u * n - 1u - p;
    }
    return texture_mod(i, n);
}

// A texel coordinate within +-2^28, 0 for a NaN or an infinity. Rust twin: texture::coord.
float texture_coord(float x) {
    if (!is_finite_f(x)) return 0.0;
    return clamp(x, -268435456.0, 268435456.0);
}

vec3 texture_texel(uvec4 h, int x, int y) {
    uint wrap = h.w >> 4u;
    uint tx = texture_wrap(x, h.y, wrap);
    uint ty = texture_wrap(y, h.z, wrap);
    return imageLoad(image_texels, int(h.x + ty * h.y + tx)).xyz;
}

// The value of texture t at surface coordinates uv. Rust twin: Texture::lookup.
vec3 texture_lookup(uint t, vec2 uv) {
    uvec4 h = texture_info_at(1u + 3u * t);
    vec3 r0 = uintBitsToFloat(texture_info_at(2u + 3u * t).xyz);
    vec3 r1 = uintBitsToFloat(texture_info_at(3u + 3u * t).xyz);
    precise float u = r0.x * uv.x + r0.y * uv.y + r0.z;
    precise float v = r1.x * uv.x + r1.y * uv.y + r1.z;
    float w = float(h.y);
    float hh = float(h.z);
    if ((h.w & 15u) == TEXTURE_NEAREST) {
        precise float su = u * w;
        precise float sv = v * hh;
        return texture_texel(h, int(floor(texture_coord(su))), int(floor(texture_coord(sv))));
    }
    precise float s0 = u * w - 0.5;
    precise float t0 = v * hh - 0.5;
    float s = texture_coord(s0);
    float tt = texture_coord(t0);
    float fs = floor(s);
    float ft = floor(tt);
    int x0 = int(fs);
    int y0 = int(ft);
    precise float ax = s - fs;
    precise float ay = tt - ft;
    precise vec3 a = texture_texel(h, x0, y0) * (1.0 - ax) + texture_texel(h, x0 + 1, y0) * ax;
    precise vec3 b = texture_texel(h, x0, y0 + 1) * (1.0 - ax) + texture_texel(h, x0 + 1, y0 + 1) * ax;
    precise vec3 r = a * (1.0 - ay) + b * ay;
    return r;
}

// A direction from a turned sphere's centre in the sphere's own frame: the rotation by the unit
// quaternion q, then z negated for a mirror (Rust: SphereFrame::to_local, the same steps).
vec3 sphere_local(vec4 q, bool mirror, vec3 d) {
    precise vec3 t = cross(q.xyz, d) * 2.0;
    precise vec3 r = d + t * q.w + cross(q.xyz, t);
    return mirror ? vec3(r.x, r.y, -r.z) : r;
}

// (u, v) of a point on a sphere, d = (p - centre) / radius (Rust: texture::sphere_uv).
vec2 sphere_uv(vec3 d) {
    precise float u = atan2_f32(d.y, d.x) * 0.15915494;
    if (u < 0.0) u += 1.0;
    precise float rho = sqrt(d.x * d.x + d.y * d.y);
    precise float v = atan2_f32(rho, d.z) * 0.31830987;
    return vec2(u, v);
}

// (u, v) of the surface point p of a hit (Rust: texture::hit_uv): a sphere's own, a triangle's
// interpolated texture coordinates or (b1, b2) without them.
vec2 surface_uv(uint prim, vec2 bary, vec3 p) {
#ifdef BVH_SPHERES
    if ((prim & SPHERE_BIT) != 0u) {
        vec4 cr;
        uvec4 info;
        sphere_texels(prim & ~SPHERE_BIT, cr, info);
        precise vec3 d = (p - cr.xyz) / cr.w;
        if ((info.w & 1u) != 0u) {
            d = sphere_local(sphere_texel(SPHERE_TEXELS * (prim & ~SPHERE_BIT) + 2u), (info.w & 2u) != 0u, d);
        }
        return sphere_uv(d);
    }
#endif
#ifdef SCENE_UVS
    vec4 vv = tri_attr(4u * prim + 3u);
    if ((floatBitsToUint(vv.w) & 2u) != 0u) {
        vec2 t0 = vec2(tri_attr(4u * prim).w, vv.x);
        vec2 t1 = vec2(tri_attr(4u * prim + 1u).w, vv.y);
        vec2 t2 = vec2(tri_attr(4u * prim + 2u).w, vv.z);
        precise float b0 = 1.0 - bary.x - bary.y;
        precise vec2 r = t0 * b0 + t1 * bary.x + t2 * bary.y;
        return r;
    }
#endif
    return bary;
}

// Writes value v of a textured parameter at word `word` of m.p[] as `mode` says (Rust:
// brdf::textured::SlotMode).
void texture_write(inout Material m, uint word, uint mode, vec3 v) {
    if (mode == TEXTURE_SLOT_RGB) {
        m.p[word / 4u][word % 4u] = v.x;
        m.p[(word + 1u) / 4u][(word + 1u) % 4u] = v.y;
        m.p[(word + 2u) / 4u][(word + 2u) % 4u] = v.z;
    } else if (mode == TEXTURE_SLOT_SPLAT) {
        for (uint k = 0u; k < 3u; ++k) m.p[(word + k) / 4u][(word + k) % 4u] = v.x;
    } else if (mode == TEXTURE_SLOT_ANGLE) {
        float a = radians(v.x);
        m.p[word / 4u][word % 4u] = cos(a);
        m.p[(word + 1u) / 4u][(word + 1u) % 4u] = sin(a);
    } else {
        m.p[word / 4u][word % 4u] = v.x;
    }
}

// The values of m's textured parameters at uv, written into its record (header.w: its list in
// texture_info, 0 for none); the caller then lets the model derive the rest (BRDF_TEXTURED).
void apply_textures(inout Material m, vec2 uv) {
    uint list = m.header.w;
    uint n = texture_info_at(list).x;
    for (uint k = 0u; k < n; ++k) {
        uvec4 b = texture_info_at(list + 1u + k);
        texture_write(m, b.y, b.z, texture_lookup(b.x, uv));
    }
}

#endif
#endif
