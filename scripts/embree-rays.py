"""Mitsuba 3's traversal (Embree, through `llvm_ad_rgb`) on the kinds of rays `brdfwave rays`
traces: the CPU reference's peer beside brdfwave's own traversal. Run it through
scripts/embree-rays.sh, which converts the scene and prints brdfwave's figures beside these.

Usage: python3 embree-rays.py SCENE.xml [RES] [PER_PIXEL]

SCENE.xml as `brdfwave convert --to mitsuba` writes it. The rays are made the way
`brdfwave rays` makes them, by Mitsuba on its own random numbers (so the same kinds and
distributions of rays, not the same rays): PER_PIXEL (default 4) camera rays per pixel of a
RES x RES image (default 256), each at a uniform point of its pixel; from each camera hit one
cosine-distributed bounce ray and one shadow ray toward a point of an emitter
(`sample_emitter_direction`, area sampling). Timed as brdfwave times its own: warm, the
fastest of 5 runs; closest hits with `ray_intersect_preliminary` (t, primitive and
barycentrics only, as brdfwave's traversal returns), shadow rays with `ray_test`. Dr.Jit
traces the array on all the host's threads, 16 rays to a packet on AVX-512 (consecutive
rays: neighbouring pixels). A second line traces the same rays shuffled, so that a packet
holds unrelated rays: what Embree's packets gain from coherence.
"""
import sys
import time

import drjit as dr
import mitsuba as mi
import numpy as np

if not 2 <= len(sys.argv) <= 4:
    sys.exit(__doc__.split("\n\n")[1])
mi.set_variant("llvm_ad_rgb")
scene = mi.load_file(sys.argv[1])
res = int(sys.argv[2]) if len(sys.argv) > 2 else 256
per = int(sys.argv[3]) if len(sys.argv) > 3 else 4
n = res * res * per

sampler = mi.load_dict({"type": "independent"})
sampler.seed(1, n)
pixel = dr.arange(mi.UInt32, n) // per
pos = (mi.Point2f(mi.Float(pixel % res), mi.Float(pixel // res)) + sampler.next_2d()) / res
camera, _ = scene.sensors()[0].sample_ray(0.0, 0.5, pos, mi.Point2f(0.5))
camera = mi.Ray3f(camera)
si = scene.ray_intersect(camera)
hit = dr.compress(si.is_valid())
m = dr.width(hit)
si = dr.gather(type(si), si, hit)
bounce = si.spawn_ray(si.to_world(mi.warp.square_to_cosine_hemisphere(
    dr.gather(mi.Point2f, sampler.next_2d(), hit))))
ds, _ = scene.sample_emitter_direction(si, dr.gather(mi.Point2f, sampler.next_2d(), hit), False)
shadow = si.spawn_ray_to(ds.p)
dr.eval(camera, bounce, shadow)


def fastest(trace, rays, runs=5):
    dr.eval(trace(rays))  # warm: compiles the kernel
    best = float("inf")
    for _ in range(runs):
        dr.sync_thread()
        t = time.perf_counter()
        dr.eval(trace(rays))
        dr.sync_thread()
        best = min(best, time.perf_counter() - t)
    return dr.width(rays) / best / 1e6


def closest(r):
    return scene.ray_intersect_preliminary(r).t


def line(label, rays):
    c, b, s = rays
    print(f"| {label} | {fastest(closest, c):.3f} | {fastest(closest, b):.3f} "
          f"| {fastest(scene.ray_test, s):.3f} |")


print(f"Mitsuba {mi.__version__} llvm_ad_rgb (Embree), {sys.argv[1]}: {n} camera rays, "
      f"{m} bounce and {m} shadow rays; M rays/s.")
print()
print("| order | camera | bounce | shadow |")
print("|---|---|---|---|")
line("pixel order", (camera, bounce, shadow))
rng = np.random.default_rng(7)


def shuffled(r):
    p = mi.UInt32(rng.permutation(dr.width(r)).astype(np.uint32))
    r = dr.gather(mi.Ray3f, r, p)
    dr.eval(r)  # the gather itself out of the timing
    return r


line("shuffled", tuple(shuffled(r) for r in (camera, bounce, shadow)))
