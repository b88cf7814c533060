"""Streaming-step benchmark of the C++ LSTM engine against RTNeural's compile-time LSTM.

RTNeural (https://github.com/jatinchowdhury18/RTNeural, BSD-3) is not part of terrasph and is
not downloaded here: pass the path of a checkout you obtained yourself. The script exports one
seeded standard-cell model per hidden size (4 inputs, 2 outputs, the weights of
benchmarks/performance/bench_lstm.py), compiles benchmarks/peers/lstm_vs_rtneural.cpp once per flag set (both
engines in one program, so the same flags), and prints ns per streaming step of each side, best
of --repeats timings of --steps steps, interleaved, with the largest output difference (the two
agree to float rounding if the weights were transferred right) and the kernel variant terrasph
ran ("generic": the flags' own; a baseline build such as plain -O3 chooses "avx2" or "avx512" at
run time, capped by the environment variable TERRASPH_LSTM_ISA).

    python benchmarks/peers/bench_lstm_rtneural.py --rtneural PATH/TO/RTNeural \\
        [--flags "-O3" "-O3 -march=native"] [--steps 2000] [--repeats 30] [--cxx g++]
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import torch
from terrasph.surrogate.export import from_torch, model_to_bytes
from terrasph.surrogate.model import ModelConfig, SurrogateNet

ROOT = Path(__file__).resolve().parents[2]
HIDDEN = (16, 32, 64, 128)  # compiled into lstm_vs_rtneural.cpp (RTNeural sizes are templates)


def eigen_include() -> str:
    """Eigen's include directory: the cmeel-eigen wheel terrasph builds with."""
    prefix = subprocess.run([sys.executable, "-m", "cmeel", "cmake"], capture_output=True,
                            text=True, check=True).stdout.strip()
    return str(Path(prefix) / "include" / "eigen3")


def write_models(out: Path) -> list[Path]:
    """One seeded 1-layer standard model per hidden size, as bench_lstm.make_models makes."""
    paths = []
    for hidden in HIDDEN:
        torch.manual_seed(hidden)
        net = SurrogateNet(ModelConfig("standard", 4, hidden, 1, 2)).eval()
        path = out / f"h{hidden}.tslstm"
        path.write_bytes(model_to_bytes(from_torch(net, [f"x{j}" for j in range(4)],
                                                   ["y0", "y1"])))
        paths.append(path)
    return paths


def main() -> None:
    """Build, run and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rtneural", type=Path, required=True,
                    help="root of an RTNeural checkout (holds RTNeural/ and modules/json)")
    ap.add_argument("--flags", nargs="+", default=["-O3", "-O3 -march=native"])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--cxx", default="g++")
    args = ap.parse_args()
    if not (args.rtneural / "RTNeural" / "RTNeural.h").exists():
        raise SystemExit(f"--rtneural: {args.rtneural} has no RTNeural/RTNeural.h")

    with tempfile.TemporaryDirectory() as tmp:
        models = write_models(Path(tmp))
        print(f"# streaming step, ns (best of {args.repeats} x {args.steps} steps, interleaved); 4 -> H -> 2, float32"
              )
        print(f"{'flags':<20} {'H':>4} {'terrasph':>10} {'RTNeural':>10} {'RTN/terrasph':>12} "
              f"{'max |dy|':>9} {'kernels':>8}")
        for flags in args.flags:
            exe = Path(tmp) / "lstm_vs_rtneural"
            cmd = [args.cxx, "-std=c++17", *shlex.split(flags), "-DNDEBUG",
                   f"-I{args.rtneural}", f"-I{ROOT / 'cpp/lstm/include'}",
                   "-isystem", eigen_include(), str(ROOT / "benchmarks/peers/lstm_vs_rtneural.cpp"),
                   "-o", str(exe)]
            build = subprocess.run(cmd, capture_output=True, text=True)
            if build.returncode != 0:
                raise SystemExit(f"building with {flags!r} failed:\n{shlex.join(cmd)}\n"
                                 + "\n".join(build.stderr.splitlines()[:20]))
            out = subprocess.run([str(exe), str(args.steps), str(args.repeats),
                                  *map(str, models)], check=True, capture_output=True,
                                 text=True).stdout
            for line in out.strip().splitlines():
                hidden, t_ts, t_rt, diff, isa = line.split()
                print(f"{flags:<20} {hidden:>4} {float(t_ts):>10.1f} {float(t_rt):>10.1f} "
                      f"{float(t_rt) / float(t_ts):>12.2f} {float(diff):>9.2g} {isa:>8}", flush=True)


if __name__ == "__main__":
    main()
