"""The standalone C++ side: the header compiles warning-free without Python, the example program
(cpp/examples/lstm_predict.cpp) reproduces the Python-module predictions (also for a model found
by name, as the package ships them), and a time step
performs no heap allocation (a counting global operator new and Eigen's EIGEN_RUNTIME_NO_MALLOC
guard)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from lstm_helpers import core_lstm, inputs, make_net, model_bytes
from terrasph.surrogate.registry import available

torch = pytest.importorskip("torch")

ROOT = Path(__file__).resolve().parents[1]
WARNINGS = ["-Wall", "-Wextra", "-Wpedantic", "-Wshadow", "-Wconversion", "-Wno-sign-conversion"]

NO_MALLOC_SRC = r"""
#define EIGEN_RUNTIME_NO_MALLOC
#include <terrasph/lstm.hpp>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <vector>
static long g_allocations = 0;  // every operator new in the program is counted
#if defined(__GNUC__) && !defined(__clang__)
// GCC cannot tell that these replacements pair malloc with free by design.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif
void* operator new(std::size_t n) {
  ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
template <typename S> int check(const char* path) {
  auto model = terrasph::lstm::Model<S>::load(path);
  terrasph::lstm::Stream<S> stream(model);
  terrasph::lstm::Batch<S> batch(model, 7);
  std::vector<S> x(static_cast<std::size_t>(7 * model->input_size()), S(0.5));
  std::vector<S> y(static_cast<std::size_t>(7 * model->output_size()));
  const long before = g_allocations;
  Eigen::internal::set_is_malloc_allowed(false);  // any Eigen heap allocation now aborts
  for (int t = 0; t < 50; ++t) {
    x[0] = S(t) / S(10);
    stream.step(x.data(), y.data());
    batch.step(x.data(), y.data());
  }
  stream.reset();
  stream.run(x.data(), 1, y.data());
  batch.reset();
  batch.run(x.data(), 1, y.data());
  Eigen::internal::set_is_malloc_allowed(true);
  if (g_allocations != before) { std::printf("allocated\n"); return 1; }
  std::printf("%s ok %g\n", sizeof(S) == 4 ? "float" : "double", double(y[0]));
  return 0;
}
int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (check<float>(argv[i]) || check<double>(argv[i])) return 1;
  return 0;
}
"""


def _eigen_include() -> Path | None:
    try:
        prefix = subprocess.run([sys.executable, "-m", "cmeel", "cmake"], capture_output=True,
                                text=True, check=True).stdout.strip()
        cand = Path(prefix) / "include" / "eigen3"
        if (cand / "Eigen" / "Core").exists():
            return cand
    except (OSError, subprocess.CalledProcessError):
        pass
    sys_eigen = Path("/usr/include/eigen3")
    return sys_eigen if (sys_eigen / "Eigen" / "Core").exists() else None


@pytest.fixture(scope="module")
def compiler() -> list[str]:
    cxx = shutil.which("g++") or shutil.which("clang++")
    eigen = _eigen_include()
    if cxx is None or eigen is None:
        pytest.skip("needs a C++ compiler and Eigen headers")
    return [cxx, "-std=c++17", "-O1", *WARNINGS, f"-I{ROOT / 'cpp/lstm/include'}",
            "-isystem", str(eigen)]


def _compile(cmd: list[str], src: Path, exe: Path) -> None:
    proc = subprocess.run([*cmd, str(src), "-o", str(exe)], capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in proc.stderr, f"C++ warnings:\n{proc.stderr}"


@pytest.fixture(scope="module")
def models(tmp_path_factory) -> list[Path]:
    d = tmp_path_factory.mktemp("cppmodels")
    out = []
    for cell, hidden, layers in (("standard", 16, 1), ("peephole", 8, 3)):
        p = d / f"{cell}.tslstm"
        p.write_bytes(model_bytes(make_net(cell, hidden, layers, seed=hidden, normalise=True)))
        out.append(p)
    return out


@pytest.fixture(scope="module")
def example_program(compiler, tmp_path_factory) -> Path:
    """cpp/examples/lstm_predict.cpp compiled (warning-free)."""
    exe = tmp_path_factory.mktemp("example") / "lstm_predict"
    _compile(compiler, ROOT / "cpp/examples/lstm_predict.cpp", exe)
    return exe


def test_example_program_matches_python_module(example_program, models, tmp_path) -> None:
    """lstm_predict (pure C++, streaming) == Model64/Model32.predict: float64 to 1e-12 and
    float32 to 1e-5 (same header, different optimisation flags may reorder no arithmetic
    except inside Eigen kernels); bad files give exit code 1 and a message, not a crash."""
    lstm = core_lstm()
    exe = example_program
    x = inputs(3, 1, 40)[0]
    csv = tmp_path / "in.csv"
    np.savetxt(csv, x, delimiter=",", header="omega_cmd,load,soil_k,mu", comments="")
    for path in models:
        for flag, cls, tol in (([], lstm.Model64, 1e-12), (["--float32"], lstm.Model32, 1e-5)):
            proc = subprocess.run([str(exe), str(path), str(csv), *flag], capture_output=True,
                                  text=True, check=True)
            lines = proc.stdout.strip().splitlines()
            assert lines[0] == "slip,sinkage"
            got = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
            ref = cls(str(path)).predict(x.astype(np.float32 if flag else np.float64))
            assert got.shape == ref.shape and np.max(np.abs(got - ref)) <= tol

    broken = tmp_path / "broken.tslstm"
    broken.write_bytes(models[0].read_bytes()[:-10])
    proc = subprocess.run([str(exe), str(broken), str(csv)], capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 1 and "CRC-32" in proc.stderr
    bad_csv = tmp_path / "bad.csv"
    bad_csv.write_text("1,2,3\n")
    proc = subprocess.run([str(exe), str(models[0]), str(bad_csv)], capture_output=True,
                          text=True, check=False)
    assert proc.returncode == 1 and "expected 4 columns, got 3" in proc.stderr


def test_step_is_allocation_free(compiler, models, tmp_path) -> None:
    """After construction, 50 steps, reset and run of a Stream and of a Batch of 7, both cells,
    float and double, call operator new zero times (counted by a replaced global operator new)
    and no Eigen allocation (Eigen's malloc guard would abort the program)."""
    src = tmp_path / "no_malloc.cpp"
    src.write_text(NO_MALLOC_SRC)
    exe = tmp_path / "no_malloc"
    _compile(compiler, src, exe)
    proc = subprocess.run([str(exe), *map(str, models)], capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.count(" ok ") == 4


def _tiny_shipped_model(models_dir: Path) -> str:
    """A model of the leg-wheel's inputs with a validity record, as the study ships one, in `models_dir`."""
    from terrasph.surrogate.export import export_model
    from terrasph.surrogate.validity import Validity

    features = ["omega_cmd", "load", "wheel:c-leg", "wheel:wheel"]
    validity = Validity(dt=0.02, duration=6.0, ranges={"omega_cmd": (0.5, 3.0), "load": (2.0, 8.0)},
                        morphologies=("c-leg", "wheel"))
    export_model(make_net("peephole", 8, 2, seed=5, n_in=4, n_out=3, normalise=True), models_dir / "tiny.tslstm",
                 features, ["slip", "sinkage", "forward_speed"], {"validity": validity.to_json(), "dt": 0.02})
    return "tiny"


@pytest.mark.parametrize("shipped", [None, *available()])
def test_example_program_predicts_with_a_model_found_by_name(example_program, tmp_path, shipped) -> None:
    """C++ reads the file that ``pretrained_path(NAME)`` gives (each model shipped with the package, and
    a small one written to a models directory as the study ships one) and predicts, over a 6 s
    ramp of the commanded ω through the model's validity range, what ``pretrained(NAME)`` predicts
    in Python (float64, to 1e-12 as above)."""
    from terrasph.surrogate.registry import pretrained, pretrained_path

    models_dir = None if shipped else tmp_path
    name = shipped or _tiny_shipped_model(tmp_path)
    model = pretrained(name, models_dir=models_dir)
    validity = model.validity
    steps = int(round(6.0 / validity.dt)) + 1
    first = f"wheel:{validity.morphologies[0]}"
    columns = {f: (np.linspace(*validity.ranges[f], steps) if f in validity.ranges else
                   np.full(steps, float(f == first))) for f in model.feature_names}
    csv = tmp_path / "inputs.csv"
    np.savetxt(csv, np.column_stack([columns[f] for f in model.feature_names]), delimiter=",",
               header=",".join(model.feature_names), comments="")
    proc = subprocess.run([str(example_program), str(pretrained_path(name, models_dir)), str(csv)],
                          capture_output=True, text=True, check=True)
    lines = proc.stdout.strip().splitlines()
    assert lines[0] == ",".join(model.target_names)
    got = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    expected = model.engine.predict(np.column_stack([columns[f] for f in model.feature_names]))
    assert got.shape == expected.shape == (steps, len(model.target_names))
    assert np.max(np.abs(got - expected)) <= 1e-12


def test_the_standalone_example_builds_only_the_lstm(tmp_path) -> None:
    """The build the docs give for the C++ example (-DTERRASPH_BUILD_EXAMPLES=ON -DTERRASPH_PYTHON=OFF)
    has the example and not the SPH core (which took two minutes to compile and is not used by it),
    and its folder, build-ex/, is ignored by git."""
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed")
    root = Path(__file__).resolve().parents[1]
    build = tmp_path / "build-ex"
    subprocess.run(["cmake", "-S", str(root), "-B", str(build), "-DTERRASPH_BUILD_EXAMPLES=ON",
                    "-DTERRASPH_PYTHON=OFF"], check=True, capture_output=True, text=True, timeout=300)
    targets = subprocess.run(["cmake", "--build", str(build), "--target", "help"], check=True, capture_output=True,
                             text=True, timeout=120).stdout
    assert "lstm_predict" in targets and "terrasph_core" not in targets
    ignored = subprocess.run(["git", "-C", str(root), "check-ignore", "-q", "build-ex/lstm_predict"])
    assert ignored.returncode == 0
