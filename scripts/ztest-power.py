#!/usr/bin/env python3
"""The false-alarm rate and the power of `brdfwave diff --z-test`, measured over many seeds.

The Cornell box (scenes/cornell-box.toml) at 128x128 and 64 spp, rendered on the CPU reference
with many seeds, as it is and with its white material (floor, ceiling, back wall, blocks) 1 %,
2 % and 5 % darker. For each configuration (sampler, and where the z-test's variance comes from:
`one-sample`, the variance of one sample over the spp, or `batches`, the variance of the mean
from `render --batches K`):

* false alarms: pairs of renders of the true scene with different seeds, each render in two
  consecutive pairs (t1 t2, t2 t3, ...: the rate is unbiased, its pairs not all independent),
  tested at each alpha of ALPHAS: the fraction that fails must be at most alpha;
* detection: a render of the darker scene against one of the true scene, every pair disjoint,
  tested at alpha 0.01: the fraction that fails;
* power as the test reports it: the median over the true pairs of the smallest relative bias the
  whole-image test and the 32x32 blocks would have detected.

Each rate is printed with its count and a 95 % Clopper-Pearson interval. With the
`independent` sampler a batched render is the unbatched one (the same samples, the same
image), so one set of batched renders serves both variance sources; with `multijitter` a
batched render draws a pattern per batch, so the one-sample configuration renders without
batches (the default render) and the batches configuration with them.

    python3 scripts/ztest-power.py [OUTDIR]        # default out/ztest-power

Then, where numpy and Mitsuba (for its EXR reader) are installed, how right each variance
is: the standard deviation of a pixel's, a 16x16 block's and the whole image's mean across
the seeds against the one each variance predicts.

Environment: SEEDS (renders of each scene per configuration, default 100), SAMPLERS (default
"multijitter independent"), BATCHES (K, default 8), ALPHAS (default "0.01 0.05 0.1 0.2"),
DARKER (per cent, default "1 2 5"), RES (default 128x128), SPP (default 64), BACKEND (default
cpu). 2 + 3 renders per seed and set of renders, of 2-8 s each on 2 cores: with the defaults,
3 sets x 100 x 5 renders, 1.5 to 3 hours, and 15 minutes of diffs. Renders are kept in OUTDIR
and reused when the script runs again.
"""

import json
import math
import os
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "cornell-box.toml"


def env(name, default):
    return os.environ.get(name, default)


def binomial_cdf(k, n, p):
    """P(X <= k) for X ~ Binomial(n, p), summed exactly (n is a few hundred here)."""
    if p <= 0.0:
        return 1.0
    if p >= 1.0:
        return 1.0 if k >= n else 0.0
    total = 0.0
    for j in range(0, k + 1):
        total += math.exp(math.lgamma(n + 1) - math.lgamma(j + 1) - math.lgamma(n - j + 1)
                          + j * math.log(p) + (n - j) * math.log1p(-p))
    return min(total, 1.0)


def clopper_pearson(k, n):
    """The 95 % Clopper-Pearson interval of a binomial proportion k / n: the p where
    P(X >= k) = 0.025 and where P(X <= k) = 0.025, by bisection."""
    def solve(f):
        lo, hi = 0.0, 1.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if f(mid):
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    lo = 0.0 if k == 0 else solve(lambda p: 1.0 - binomial_cdf(k - 1, n, p) < 0.025)
    hi = 1.0 if k == n else solve(lambda p: binomial_cdf(k, n, p) > 0.025)
    return lo, hi


def rate(k, n):
    lo, hi = clopper_pearson(k, n)
    return f"{k}/{n} = {k / n:.3f} [{lo:.3f}, {hi:.3f}]"


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/ztest-power")
    seeds = int(env("SEEDS", "100"))
    samplers = env("SAMPLERS", "multijitter independent").split()
    batches = int(env("BATCHES", "8"))
    alphas = [float(a) for a in env("ALPHAS", "0.01 0.05 0.1 0.2").split()]
    res, spp, backend = env("RES", "128x128"), env("SPP", "64"), env("BACKEND", "cpu")
    subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)
    binary = ROOT / "target" / "release" / "brdfwave"
    albedo = tomllib.loads(SCENE.read_text())["materials"]["white"]["albedo"]
    levels = env("DARKER", "1 2 5").split()
    darker = {
        d: "materials.white.albedo=[" + ", ".join(f"{c * (1 - float(d) / 100):.6g}" for c in albedo) + "]"
        for d in levels
    }

    def render(path, seed, sampler, batched, override=None):
        if path.exists():
            return
        cmd = [str(binary), "render", str(SCENE), "--backend", backend, "--res", res,
               "--spp", spp, "--seed", str(seed), "--sampler", sampler, "--out", str(path), "--quiet"]
        if batched:
            cmd += ["--batches", str(batches)]
        if override:
            cmd += ["--set", override]
        subprocess.run(cmd, check=True)

    def diff(test, ref, alpha, source):
        cmd = [str(binary), "diff", str(test), str(ref), "--z-test", "--json", "--alpha", str(alpha),
               "--variance-source", source]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode not in (0, 1):
            sys.exit(f"{' '.join(cmd)} failed: {r.stderr}")
        return json.loads(r.stdout)["z_test"]

    # (sampler, variance source, whether the renders are batched)
    configs = []
    for sampler in samplers:
        configs.append((sampler, "one-sample", sampler != "multijitter"))
        configs.append((sampler, "batches", True))
    print(f"Cornell box {res}, {spp} spp, {backend} backend, {seeds} renders per scene; "
          f"batches: K = {batches}; darker white: {', '.join(darker.values())}")
    print()
    header = ("| sampler | variance | " + " | ".join(f"false alarms, alpha {a:g}" for a in alphas)
              + "".join(f" | {d} % darker detected" for d in levels)
              + " | detectable bias, whole image | detectable bias, 32x32 |")
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for sampler, source, batched in configs:
        d = out / f"{sampler}-{'batched' if batched else 'plain'}"
        d.mkdir(parents=True, exist_ok=True)
        true = []
        for i in range(2 * seeds):
            p = d / f"true-{i}.exr"
            render(p, 1000 + i, sampler, batched)
            true.append(p)
        dark = {}
        for name, override in darker.items():
            dark[name] = []
            for i in range(seeds):
                p = d / f"dark{name}-{i}.exr"
                render(p, 5000 + round(1000 * float(name)) + i, sampler, batched, override)
                dark[name].append(p)
        alarms = {a: 0 for a in alphas}
        whole, b32 = [], []
        pairs = list(zip(true, true[1:]))
        for a, b in pairs:
            for alpha in alphas:
                z = diff(a, b, alpha, source)
                alarms[alpha] += not z["pass"]
                if alpha == 0.01:
                    scales = z["blocks"]["scales"]
                    whole.append(scales[-1]["detectable"]["bias"])
                    b32 += [s["detectable"]["typical_bias"] for s in scales if s["side"] == 32]
        detected = {}
        for li, (name, renders) in enumerate(dark.items()):
            refs = true[li % 2::2]
            detected[name] = sum(not diff(t, r, 0.01, source)["pass"] for t, r in zip(renders, refs))
        median = lambda v: sorted(v)[len(v) // 2] if v else float("nan")
        print(f"| {sampler} | {source} | "
              + " | ".join(rate(alarms[a], len(pairs)) for a in alphas)
              + "".join(f" | {rate(detected[d], seeds)}" for d in levels)
              + f" | {100 * median(whole):.3f} % | {100 * median(b32):.3f} % (typical block) |",
              flush=True)


def variance_check(out, samplers, seeds, spp):
    """How right each variance is: over the renders of the true scene, the standard deviation of
    a pixel's, a 16x16 block's and the whole image's mean across seeds, against the one each
    variance predicts (the mean over seeds of the estimate; a ratio of 1 is right, above 1
    overstates). Needs numpy and Mitsuba's EXR reader; skipped with a message without them."""
    try:
        import numpy as np
        import mitsuba as mi
        mi.set_variant("scalar_rgb")
    except Exception as e:  # noqa: BLE001 - any import failure means: skip
        print(f"\n(variance check skipped: numpy and mitsuba are needed to read the EXRs: {e})")
        return
    print()
    print("Estimated / actual standard deviation of the mean (actual: across the seeds; estimated:"
          " the root of the mean estimated variance):")
    print()
    print("| sampler | renders | variance | pixel (median) | 16x16 block (median) | whole image |")
    print("|---|---|---|---|---|---|")

    def layer(b, names):
        fields = [b.struct_()[i].name for i in range(b.channel_count())]
        a = np.array(b, copy=False)
        return np.stack([a[..., fields.index(n)] for n in names], axis=-1).astype(np.float64)

    def blocks(x, k):
        h, w = x.shape[-3], x.shape[-2]
        return x[..., : h // k * k, : w // k * k, :].reshape(
            x.shape[:-3] + (h // k, k, w // k, k, 3)).mean(axis=(-4, -2))

    for sampler in samplers:
        for batched in ([False, True] if sampler == "multijitter" else [True]):
            d = out / f"{sampler}-{'batched' if batched else 'plain'}"
            paths = [d / f"true-{i}.exr" for i in range(2 * seeds)]
            if not all(p.exists() for p in paths):
                continue
            means, one, of_mean = [], [], []
            for p in paths:
                b = mi.Bitmap(str(p))
                means.append(layer(b, ["R", "G", "B"]))
                one.append(layer(b, ["variance.R", "variance.G", "variance.B"]) / float(spp))
                if batched:
                    of_mean.append(layer(b, ["meanVariance.R", "meanVariance.G", "meanVariance.B"]))
            means = np.array(means)
            sources = [("one-sample", np.array(one))]
            if batched:
                sources.append(("batches", np.array(of_mean)))
            for name, var in sources:
                row = []
                for k in (1, 16, None):
                    if k is None:
                        m = means.mean(axis=(1, 2))
                        v = var.sum(axis=(1, 2)) / (means.shape[1] * means.shape[2]) ** 2
                    elif k == 1:
                        m, v = means, var
                    else:
                        m = blocks(means, k)
                        v = blocks(var, k) / (k * k)
                    actual = m.std(axis=0, ddof=1)
                    estimated = np.sqrt(v.mean(axis=0))
                    keep = actual > 0
                    row.append(np.median(estimated[keep] / actual[keep]))
                print(f"| {sampler} | {'batched' if batched else 'plain'} | {name} | "
                      + " | ".join(f"{r:.2f}" for r in row) + " |", flush=True)


if __name__ == "__main__":
    main()
    variance_check(
        Path(sys.argv[1] if len(sys.argv) > 1 else "out/ztest-power"),
        env("SAMPLERS", "multijitter independent").split(),
        int(env("SEEDS", "100")),
        int(env("SPP", "64")),
    )
