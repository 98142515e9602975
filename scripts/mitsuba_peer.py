"""Mitsuba 3 as a peer configuration of `brdfwave bench`.

Usage: python3 mitsuba_peer.py VARIANT SAMPLER SCENE.xml OUTDIR

SCENE.xml is the benchmarked scene as `brdfwave convert --to mitsuba` writes it (its meshes in
OBJ files beside it): Mitsuba's `path` integrator with max_depth = brdfwave's max_depth (both
count path segments, the camera segment first) and Russian roulette off, a box pixel filter
one pixel wide. This script only replaces the sensor's sampler by the plugin SAMPLER
(`independent`, `stratified`, `multijitter`, `orthogonal` or `ldsampler`); the sample count
comes with each render.

Protocol, one line each way (so that the benchmark can interleave this process's renders with
its own configurations). The first line this script writes is
`ready COMPILE_SECONDS PLAIN_SPP PLAIN_SECONDS LOAD_SECONDS`, or `error MESSAGE`: the faster
of two plain warm renders of PLAIN_SPP samples per pixel, the figure a user sees, after a first render of
the same size that compiles Dr.Jit's kernels (COMPILE_SECONDS: how much longer that one
took); LOAD_SECONDS is the scene's load (`mi.load_string`: parsing the XML and the meshes and
building Mitsuba's acceleration structure). Then brdfwave
writes `render N REPEAT_BELOW` and this script renders a fresh image of N samples per pixel
(a stratified sampler loses its stratification when independent passes are averaged, so every
point of the curve is one render), timed alone; a render that took under REPEAT_BELOW seconds
is rendered and timed once more with the same seed (the same image), and SECONDS is the faster
of the two, as brdfwave times its own short renders. It answers `done SECONDS SPP COMPILE_SECONDS PATH` with
the samples per pixel the sampler actually took (stratified samplers round N up to a square,
`ldsampler` to a power of two), the compile time kept out of the timing and the image (linear
RGB, EXR); `quit` ends it. The kernels of the samplers other than `independent` depend on the
sample count (Dr.Jit compiles a new kernel for each one), so the first render of each count
is a warm-up, untimed, and COMPILE_SECONDS is how much longer it took than the timed one.
"""
import os
import sys
import time


PLAIN_SPP = 64


def load_scene(mi, xml_path, sampler):
    import xml.etree.ElementTree as ET

    root = ET.parse(xml_path).getroot()
    for sensor in root.iter("sensor"):
        for old in sensor.findall("sampler"):
            sensor.remove(old)
        ET.SubElement(sensor, "sampler", {"type": sampler})
    # The meshes' file names are relative to the XML's folder.
    resolver = mi.file_resolver() if hasattr(mi, "file_resolver") else mi.Thread.thread().file_resolver()
    resolver.prepend(os.path.dirname(os.path.abspath(xml_path)))
    return mi.load_string(ET.tostring(root, encoding="unicode"))


def main():
    variant, sampler, scene_path, out = sys.argv[1:5]
    try:
        import mitsuba as mi
        import numpy as np

        mi.set_variant(variant)
        # Mitsuba logs to stdout, which carries the protocol: warnings (e.g. a sample count
        # rounded up to a square) would break it.
        mi.set_log_level(mi.LogLevel.Error)
        t = time.perf_counter()
        scene = load_scene(mi, scene_path, sampler)
        load = time.perf_counter() - t

        def render(spp, seed):
            t = time.perf_counter()
            img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
            return img, time.perf_counter() - t

        # Kernel compilation: the first render of a size against the same render warm.
        _, cold = render(PLAIN_SPP, 2**31 - 1)
        # The faster of two warm renders: the first one after start-up can be slow.
        plain = min(render(PLAIN_SPP, 2**31 - k)[1] for k in (2, 3))
        print(f"ready {max(cold - plain, 0.0):.6f} {PLAIN_SPP} {plain:.6f} {load:.6f}", flush=True)
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
        repeat_below = float(words[2]) if len(words) > 2 else 0.0
        cold = None
        if n not in warm:
            _, cold = render(n, 2**30 + seed)
            warm.add(n)
        img, dt = render(n, seed)
        if dt < repeat_below:
            dt = min(dt, render(n, seed)[1])
        compile_seconds = 0.0 if cold is None else max(cold - dt, 0.0)
        seed += 1
        spp = scene.sensors()[0].sampler().sample_count()
        path = os.path.join(out, f"render{seed}.exr")
        mi.Bitmap(img.astype(np.float32)).write(path)
        print(f"done {dt:.6f} {spp} {compile_seconds:.6f} {path}", flush=True)


if __name__ == "__main__":
    main()
