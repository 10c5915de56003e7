#!/usr/bin/env -S /usr/bin/python3
"""Equal-time convergence: relMSE against render time for several methods, log-log.

Runs `segpath-render --scene S --method M --time t --reference REF --out TMP.pfm` for every
method M and time budget t, reads the relMSE the renderer prints (its summary line ends in
"..., RMSE <x>, relMSE <y>"), and writes a CSV (method, seconds, relmse) and a log-log PNG.
Needs matplotlib (Debian python3-matplotlib, installed by scripts/install-deps.sh); the
shebang uses /usr/bin/python3 for that reason.

Example:
  scripts/convergence.py --scene cornell1 --reference ref.pfm --methods pt,lt --times 1,2,4,8 \\
      --out out/convergence.png
"""

import argparse
import csv
import math
import os
import re
import subprocess
import sys
import tempfile

RELMSE = re.compile(r"relMSE[\s:=]+([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|nan|inf)", re.IGNORECASE)


def parse_relmse(output):
    """The last relMSE value in the renderer's output; ValueError when there is none."""
    matches = RELMSE.findall(output)
    if not matches:
        raise ValueError("no 'relMSE <number>' in the renderer's output")
    value = float(matches[-1])
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"relMSE {matches[-1]} is not a finite number >= 0")
    return value


def positive_numbers(text, what):
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what}: expected comma-separated numbers, got {text!r}")
    if not values or any(not math.isfinite(v) or v <= 0 for v in values):
        raise argparse.ArgumentTypeError(f"{what}: expected positive numbers, got {text!r}")
    return values


def names(text):
    values = [x.strip() for x in text.split(",") if x.strip()]
    if not values:
        raise argparse.ArgumentTypeError(f"expected comma-separated method names, got {text!r}")
    return values


def render(renderer, scene, method, seconds, reference, extra):
    with tempfile.TemporaryDirectory(prefix="segpath-convergence-") as tmp:
        out = os.path.join(tmp, "image.pfm")
        command = [renderer, "--scene", scene, "--method", method, "--time", f"{seconds:g}",
                   "--reference", reference, "--out", out] + extra
        result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"{' '.join(command)} failed with exit code {result.returncode}:\n"
                               f"{result.stderr.strip()}")
        try:
            return parse_relmse(result.stdout + "\n" + result.stderr)
        except ValueError as e:
            raise RuntimeError(f"{' '.join(command)}: {e}; output was:\n{result.stdout}{result.stderr}")


def plot(rows, methods, scene, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for method in methods:
        points = sorted((t, e) for m, t, e in rows if m == method and e > 0)
        if points:
            ax.plot([t for t, _ in points], [e for _, e in points], marker="o", label=method)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("render time (s)")
    ax.set_ylabel("relMSE")
    ax.set_title(f"{scene}: relMSE against time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scene", required=True, help="cornell0..3 or a .obj file (passed to the renderer)")
    parser.add_argument("--reference", required=True, help="reference image, .pfm or .exr")
    parser.add_argument("--methods", required=True, type=names, help="comma-separated methods, e.g. pt,lt")
    parser.add_argument("--times", required=True, type=lambda t: positive_numbers(t, "--times"),
                        help="comma-separated time budgets in seconds, e.g. 1,2,4,8")
    parser.add_argument("--renderer", default="build/examples/segpath-render", help="the segpath-render binary")
    parser.add_argument("--out", default="convergence.png", help="output plot (PNG); the CSV goes next to it")
    parser.add_argument("--csv", help="output CSV (default: --out with .csv)")
    parser.add_argument("renderer_args", nargs=argparse.REMAINDER,
                        help="after --: more arguments for every renderer run (e.g. -- --threads 2)")
    args = parser.parse_args(argv)

    extra = args.renderer_args[1:] if args.renderer_args[:1] == ["--"] else args.renderer_args
    if not os.path.isfile(args.reference):
        parser.error(f"--reference {args.reference}: no such file")
    if not (os.path.isfile(args.renderer) and os.access(args.renderer, os.X_OK)):
        parser.error(f"--renderer {args.renderer}: not an executable file (build it first)")
    csv_path = args.csv or os.path.splitext(args.out)[0] + ".csv"
    for path in (args.out, csv_path):
        directory = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(directory):
            parser.error(f"{path}: directory {directory} does not exist")

    rows = []
    for method in args.methods:
        for seconds in args.times:
            try:
                relmse = render(args.renderer, args.scene, method, seconds, args.reference, extra)
            except RuntimeError as e:
                print(f"convergence: {e}", file=sys.stderr)
                return 1
            print(f"{method:>8} {seconds:8g} s  relMSE {relmse:.6g}", flush=True)
            rows.append((method, seconds, relmse))

    with open(csv_path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["method", "seconds", "relmse"])
        for method, seconds, relmse in rows:
            writer.writerow([method, f"{seconds:g}", f"{relmse:.9g}"])
    try:
        plot(rows, args.methods, args.scene, args.out)
    except ImportError:
        print(f"convergence: wrote {csv_path}, but matplotlib is missing (run with /usr/bin/python3 "
              "or install python3-matplotlib): no plot", file=sys.stderr)
        return 1
    print(f"convergence: wrote {csv_path} and {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
