"""Mitsuba 3 as a peer configuration of `brdfwave bench`.

Usage: python3 mitsuba_peer.py VARIANT SCENE.json OUTDIR

SCENE.json is written by `brdfwave bench` from the scene it benchmarks: triangle meshes with an
RGB Lambert albedo and an optional one-sided RGB emitter each, a pinhole camera (vertical field
of view), the image size and the maximum depth. The scene is rendered with Mitsuba's `path`
integrator (max_depth = brdfwave's max_depth: both count path segments, the camera segment
first; Russian roulette off), the `independent` sampler and a box pixel filter one pixel wide.

Protocol, one line each way (so that the benchmark can interleave this process's passes with
its own configurations): brdfwave writes `pass N` (render N more samples per pixel) and this
script answers `done SECONDS PATH` once it has written the running mean of every pass so far to
PATH (linear RGB, EXR); `quit` ends it. The first line it writes is `ready SECONDS` after the
warm-up render (Dr.Jit compiles its kernels there), or `error MESSAGE`.
"""
import json
import os
import sys
import time


def load_scene(mi, desc, folder):
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
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["albedo"]}},
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
            "sampler": {"type": "independent", "sample_count": 1},
        },
    }
    env = desc.get("environment")
    if env and any(c > 0 for c in env):
        scene["environment"] = {"type": "constant", "radiance": {"type": "rgb", "value": env}}
    scene.update(shapes)
    return mi.load_dict(scene)


def main():
    variant, scene_path, out = sys.argv[1], sys.argv[2], sys.argv[3]
    try:
        import mitsuba as mi
        import numpy as np

        mi.set_variant(variant)
        with open(scene_path) as f:
            desc = json.load(f)
        scene = load_scene(mi, desc, out)
        t = time.perf_counter()
        np.array(mi.render(scene, spp=1, seed=2**31 - 1))
        print(f"ready {time.perf_counter() - t:.6f}", flush=True)
    except Exception as e:  # reported to brdfwave, which skips this configuration
        print(f"error {type(e).__name__}: {e}".replace("\n", " "), flush=True)
        return
    total = None
    spp_done = 0
    seed = 0
    for line in sys.stdin:
        words = line.split()
        if not words or words[0] == "quit":
            break
        n = int(words[1])
        t = time.perf_counter()
        img = np.array(mi.render(scene, spp=n, seed=seed), dtype=np.float64)
        dt = time.perf_counter() - t
        seed += 1
        total = img * n if total is None else total + img * n
        spp_done += n
        path = os.path.join(out, f"pass{seed}.exr")
        mi.Bitmap((total / spp_done).astype(np.float32)).write(path)
        print(f"done {dt:.6f} {path}", flush=True)


if __name__ == "__main__":
    main()
