"""Mitsuba 3 as a peer configuration of `brdfwave bench`.

Usage: python3 mitsuba_peer.py VARIANT SAMPLER SCENE.json OUTDIR

SCENE.json is written by `brdfwave bench` from the scene it benchmarks: triangle meshes, each
with its Mitsuba BSDF (`diffuse` with an RGB albedo, or `roughconductor` with a distribution,
alpha and RGB eta/k) and an optional one-sided RGB emitter, a pinhole camera (vertical field of
view), the image size and the maximum depth. The scene is rendered with Mitsuba's `path`
integrator (max_depth = brdfwave's max_depth: both count path segments, the camera segment
first; Russian roulette off), the sampler plugin SAMPLER (`independent`, `stratified`,
`multijitter`, `orthogonal` or `ldsampler`) and a box pixel filter one pixel wide.

Protocol, one line each way (so that the benchmark can interleave this process's renders with
its own configurations). The first line this script writes is
`ready COMPILE_SECONDS PLAIN_SPP PLAIN_SECONDS`, or `error MESSAGE`: one plain warm render of
PLAIN_SPP samples per pixel, the figure a user sees, after a first render of the same size
that compiles Dr.Jit's kernels (COMPILE_SECONDS: how much longer that one took). Then brdfwave
writes `render N` and this script renders a fresh image of N samples per pixel (a stratified
sampler loses its stratification when independent passes are averaged, so every point of the
curve is one render), timed alone, and answers `done SECONDS SPP COMPILE_SECONDS PATH` with
the samples per pixel the sampler actually took (stratified samplers round N up to a square,
`ldsampler` to a power of two), the compile time kept out of the timing and the image (linear
RGB, EXR); `quit` ends it. The kernels of the samplers other than `independent` depend on the
sample count (Dr.Jit compiles a new kernel for each one), so the first render of each count
is a warm-up, untimed, and COMPILE_SECONDS is how much longer it took than the timed one.
"""
import json
import os
import sys
import time


PLAIN_SPP = 64


def bsdf(b):
    rgb = lambda v: {"type": "rgb", "value": v}
    if b["type"] == "diffuse":
        return {"type": "diffuse", "reflectance": rgb(b["albedo"])}
    if b["type"] == "roughconductor":
        return {
            "type": "roughconductor",
            "distribution": b["distribution"],
            "alpha": b["alpha"],
            "eta": rgb(b["eta"]),
            "k": rgb(b["k"]),
            "sample_visible": True,
        }
    raise ValueError(f"unknown BSDF {b['type']}")


def load_scene(mi, desc, folder, sampler):
    shapes = {}
    for i, m in enumerate(desc["meshes"]):
        path = os.path.join(folder, f"mesh{i}.obj")
        with open(path, "w") as f:
            for v in m["vertices"]:
                f.write(f"v {v[0]!r} {v[1]!r} {v[2]!r}\n")
            for t in range(len(m["vertices"]) // 3):
                f.write(f"f {3 * t + 1} {3 * t + 2} {3 * t + 3}\n")
        shape = {
            "type": "obj",
            "filename": path,
            "face_normals": True,
            "bsdf": bsdf(m["bsdf"]),
        }
        if m.get("radiance") is not None:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": m["radiance"]}}
        shapes[f"mesh{i}"] = shape
    cam = desc["camera"]
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": desc["max_depth"], "rr_depth": 2**30},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": cam["fov_y"],
            "to_world": mi.ScalarTransform4f().look_at(
                origin=cam["position"], target=cam["target"], up=cam["up"]
            ),
            "film": {
                "type": "hdrfilm",
                "width": desc["width"],
                "height": desc["height"],
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
            "sampler": {"type": sampler, "sample_count": 1},
        },
    }
    env = desc.get("environment")
    if env and any(c > 0 for c in env):
        scene["environment"] = {"type": "constant", "radiance": {"type": "rgb", "value": env}}
    scene.update(shapes)
    return mi.load_dict(scene)


def main():
    variant, sampler, scene_path, out = sys.argv[1:5]
    try:
        import mitsuba as mi
        import numpy as np

        mi.set_variant(variant)
        # Mitsuba logs to stdout, which carries the protocol: warnings (e.g. a sample count
        # rounded up to a square) would break it.
        mi.set_log_level(mi.LogLevel.Error)
        with open(scene_path) as f:
            desc = json.load(f)
        scene = load_scene(mi, desc, out, sampler)

        def render(spp, seed):
            t = time.perf_counter()
            img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
            return img, time.perf_counter() - t

        # Kernel compilation: the first render of a size against the same render warm.
        _, cold = render(PLAIN_SPP, 2**31 - 1)
        _, plain = render(PLAIN_SPP, 2**31 - 2)
        print(f"ready {max(cold - plain, 0.0):.6f} {PLAIN_SPP} {plain:.6f}", flush=True)
    except Exception as e:  # reported to brdfwave, which skips this configuration
        print(f"error {type(e).__name__}: {e}".replace("\n", " "), flush=True)
        return
    seed = 0
    warm = {PLAIN_SPP}
    for line in sys.stdin:
        words = line.split()
        if not words or words[0] == "quit":
            break
        n = int(words[1])
        cold = None
        if n not in warm:
            _, cold = render(n, 2**30 + seed)
            warm.add(n)
        img, dt = render(n, seed)
        compile_seconds = 0.0 if cold is None else max(cold - dt, 0.0)
        seed += 1
        spp = scene.sensors()[0].sampler().sample_count()
        path = os.path.join(out, f"render{seed}.exr")
        mi.Bitmap(img.astype(np.float32)).write(path)
        print(f"done {dt:.6f} {spp} {compile_seconds:.6f} {path}", flush=True)


if __name__ == "__main__":
    main()
