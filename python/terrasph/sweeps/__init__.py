"""Parameter sweeps of a registered scene on Dask: ``terrasph sweep SPEC``.

Modules:
    spec: the SPEC file (YAML or TOML): scene, fixed parameters, seeded design; validated
            completely, every case built, before any run starts.
    runner: the cases on a Dask cluster (LocalCluster by default): resumable, atomic run files,
            failures recorded, progress, manifest.
    cli: the ``terrasph sweep`` command.
"""

from terrasph.sweeps.spec import Case, SweepSpec, load_spec, parse_spec

__all__ = ["Case", "SweepSpec", "load_spec", "parse_spec"]
