"""Release metadata: one version everywhere a user or a paper reads it, and a licence that matches.

The version is written once (python/terrasph/_version.py); these tests check that the package
metadata reads it from there, that the command line and a real run file report it, and that the
citation file and the changelog name the same version.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import h5py
import yaml

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the test extra installs tomli
    import tomli as tomllib

import terrasph

ROOT = Path(__file__).resolve().parent.parent


def test_pyproject_reads_the_version_from_its_one_source() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    provider = project["tool"]["scikit-build"]["metadata"]["version"]
    source = ROOT / provider["input"]
    assert source.relative_to(ROOT / "python").with_suffix("").parts == ("terrasph", "_version")
    assert re.search(r'__version__ = "([^"]+)"', source.read_text()).group(1) == terrasph.__version__


def test_version_is_pep440() -> None:
    # PEP 440's public version form (the canonical regular expression of its appendix B, without epochs)
    assert re.fullmatch(r"\d+(\.\d+)*((a|b|rc)\d+)?(\.post\d+)?(\.dev\d+)?", terrasph.__version__)


def test_command_line_and_run_file_carry_the_version(tmp_path: Path) -> None:
    printed = subprocess.run([sys.executable, "-m", "terrasph.cli", "--version"], capture_output=True, text=True,
                             check=True).stdout.strip()
    assert printed == f"terrasph {terrasph.__version__}"
    out = tmp_path / "lw.h5"  # the leg-wheel on RFT: a real run through the one run loop, in seconds
    subprocess.run([sys.executable, "-m", "terrasph.cli", "run", "leg-wheel", "--terrain", "rft", "--settle-time",
                    "0.02", "--t-end", "0.04", "--no-progress", "--out", str(out)], capture_output=True, check=True)
    with h5py.File(out, "r") as run:
        assert run.attrs["version_terrasph"] == terrasph.__version__
    with h5py.File(tmp_path / "lw.checkpoint.h5", "r") as checkpoint:
        assert checkpoint.attrs["terrasph_version"] == terrasph.__version__


def test_citation_and_changelog_name_this_version() -> None:
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert citation["cff-version"] == "1.2.0" and citation["version"] == terrasph.__version__
    release = terrasph.__version__.split(".dev")[0]
    changelog = (ROOT / "CHANGELOG.md").read_text()
    heading = f"to be released as {release}" if ".dev" in terrasph.__version__ else f"## {release} —"
    assert heading in changelog


def test_licence_matches_the_metadata() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    licence = (ROOT / "LICENSE").read_text()
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert project["license"] == {"text": "MIT"} and licence.startswith("MIT License")
    assert citation["license"] == "MIT"
