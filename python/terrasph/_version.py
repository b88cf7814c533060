"""The version of terrasph: the one place it is written.

pyproject.toml reads it (scikit-build-core's regex provider), ``terrasph --version`` prints it and
every run file stores it as the root attribute ``version_terrasph``. CHANGELOG.md lists what each
version changed for a user; CITATION.cff quotes it (tests/test_release.py checks they agree).
"""

__version__ = "0.2.0.dev0"
