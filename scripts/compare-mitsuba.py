#!/usr/bin/env python3
"""Times `lucid bench trace` against Mitsuba 3 on the same Cornell box, alternating runs.

The performance target of the path tracer (issue 9) was set against Mitsuba 3's scalar and
LLVM builds measured on a machine like ours; machines here drift in speed between days and
minutes, so a figure means something only beside the reference measured in the same run.
`mi.cornell_box()` is the layout of shared/reference/cornell-box.md, rendered here with the
benchmark's settings (256x256, 64 spp, path tracing with max depth 8; reference mean 0.1470).

    pip install mitsuba numpy
    # the LLVM variant needs libLLVM 16 or later (Debian: apt-get install libllvm19); the
    # script points Dr.Jit at the newest one it finds unless DRJIT_LIBLLVM_PATH is set
    python3 scripts/compare-mitsuba.py [--lucid PATH] [--rounds 6]

Each round runs `lucid bench trace` once and renders once with each Mitsuba variant, each in
a process of its own (the LLVM variant's kernels are compiled by an untimed render first).
Each round runs lucid from a fresh copy of its binary: on these machines one file of the same
binary ran 10 % slower than a copy of it, run after run (where the file's pages happen to lie
in memory), so the median is over several placements rather than one; the LLVM variant's
kernels are compiled into fresh memory by each process anyway. It
prints each renderer's median wall time, the ratios, and lucid's time scaled to the
machine the target was set on (where the scalar build took 3.2 s and the LLVM build 1.2 s).
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ISSUE_SECONDS = {"scalar_rgb": 3.2, "llvm_ad_rgb": 1.2}


def newest_libllvm():
    """The newest Debian libLLVM of version 16 or later (older ones failed to compile Dr.Jit
    1.5's AVX-512 kernels here), or None."""
    import glob
    import re

    found = []
    for path in glob.glob("/usr/lib/*/libLLVM-*.so") + glob.glob("/usr/lib/llvm-*/lib/libLLVM*.so"):
        m = re.search(r"LLVM-?(\d+)", os.path.basename(path)) or re.search(r"llvm-(\d+)", path)
        if m and int(m.group(1)) >= 16:
            found.append((int(m.group(1)), path))
    return max(found)[1] if found else None


def lucid_run(binary):
    """`lucid bench trace`'s wall time and image mean."""
    out = subprocess.run([binary, "bench", "trace"], check=True, capture_output=True, text=True).stdout
    values = {}
    for line in out.splitlines():
        for name in ("wall time", "image mean"):
            if line.startswith(name):
                values[name] = float(line.split()[-1])
    if len(values) < 2:
        sys.exit(f"error: `{binary} bench trace` printed no wall time or image mean line:\n{out}")
    return values["wall time"], values["image mean"]


def worker(variant, seed):
    """One timed render in a process of its own (after an untimed one for the LLVM variant),
    so that neither variant's threads share the cores with the other's."""
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    d = mi.cornell_box()
    d["sensor"]["film"]["width"] = 256
    d["sensor"]["film"]["height"] = 256
    d["sensor"]["sampler"] = {"type": "independent", "sample_count": 64}
    d["integrator"] = {"type": "path", "max_depth": 8}
    scene = mi.load_dict(d)

    def render(seed):
        start = time.perf_counter()
        image = mi.render(scene, spp=64, seed=seed)
        dr.eval(image)
        dr.sync_thread()
        return time.perf_counter() - start, float(np.asarray(image)[..., :3].mean())

    if variant.startswith("llvm"):
        render(0)
    wall, mean = render(seed)
    print(f"{wall} {mean}")


def mitsuba_run(variant, seed):
    """A worker's wall time and image mean, or the reason it failed."""
    done = subprocess.run(
        [sys.executable, __file__, "--worker", variant, "--seed", str(seed)], capture_output=True, text=True
    )
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines()
        raise RuntimeError(lines[-1] if lines else f"exit code {done.returncode}")
    wall, mean = done.stdout.split()[-2:]
    return float(wall), float(mean)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    target = os.environ.get("CARGO_TARGET_DIR", os.path.expanduser("~/.cache/lucid-target"))
    parser.add_argument("--lucid", default=os.path.join(target, "release", "lucid"))
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--seed", type=int, default=1, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args.worker, args.seed)
    if not os.path.isfile(args.lucid):
        sys.exit(f"error: {args.lucid}: no lucid binary (cargo build --release -p lucid-cli)")
    try:
        import mitsuba  # noqa: F401
        import numpy  # noqa: F401
    except ImportError as e:
        sys.exit(f"error: {e}: pip install mitsuba numpy")

    libllvm = None if "DRJIT_LIBLLVM_PATH" in os.environ else newest_libllvm()
    if libllvm:
        os.environ["DRJIT_LIBLLVM_PATH"] = libllvm
        print(f"using {libllvm} for the LLVM variant", flush=True)
    variants = list(ISSUE_SECONDS)
    times = {"lucid": []} | {v: [] for v in variants}
    means = {}
    with tempfile.TemporaryDirectory(prefix="compare-mitsuba-") as scratch:
        for r in range(args.rounds):
            copy = os.path.join(scratch, f"lucid-{r + 1}")
            shutil.copy2(args.lucid, copy)
            wall, means["lucid"] = lucid_run(copy)
            os.remove(copy)
            times["lucid"].append(wall)
            for variant in list(variants):
                try:
                    wall, means[variant] = mitsuba_run(variant, r + 1)
                except RuntimeError as e:
                    print(f"warning: Mitsuba variant {variant} failed, left out: {e}", file=sys.stderr)
                    variants.remove(variant)
                    del times[variant]
                    means.pop(variant, None)
                    continue
                times[variant].append(wall)
            print(f"round {r + 1}: " + "  ".join(f"{k} {v[-1]:.3f} s" for k, v in times.items()), flush=True)

    lucid = statistics.median(times["lucid"])
    print(f"\n{'renderer':<20}{'median (s)':>11}{'min (s)':>9}{'lucid / it':>12}{'lucid scaled (s)':>18}")
    print(f"{'lucid':<20}{lucid:>11.3f}{min(times['lucid']):>9.3f}")
    for variant in variants:
        median = statistics.median(times[variant])
        scaled = lucid / median * ISSUE_SECONDS[variant]
        print(f"{'mitsuba ' + variant:<20}{median:>11.3f}{min(times[variant]):>9.3f}{lucid / median:>12.3f}{scaled:>18.3f}")
    print("\nimage means: " + ", ".join(f"{v} {m:.5f}" for v, m in means.items()) + " (reference 0.1470)")
    print("lucid scaled: lucid's median times the issue machine's time for that variant over this run's")


if __name__ == "__main__":
    main()
