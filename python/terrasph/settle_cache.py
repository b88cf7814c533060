"""Settle once: the state at the end of a robot scene's pause, kept in a cache and shared by every run
that would settle the same bed under the same robot at rest.

What happens before the drive depends on the bed, the robot at rest on it, the numerics and the code,
not on the drive that follows. A configuration class declares its drive-only fields once, in its
``DRIVE_FIELDS`` (the leg-wheel's ω, ω(t) schedule and end time); every other field, the resolved
material, numerics, bodies and walls (the terrain coupling's ``describe()``), the versions and the compiled robot
model (its MJB bytes) and the identity of the code (a SHA-256 of the package's Python sources and of
its compiled core) make the **key**, a
SHA-256 of their canonical JSON. A field added later is part of the key unless it is declared a drive
field, so a new setting can make the cache miss, never give a wrong start.

An **entry** is the run of the pause itself: its run file (frames and series up to the end of the
pause) and its checkpoint (the state at the start of the pause's last stretch, which lies on the path
of every longer run; terrasph.run_loop), with ``entry.json`` (the key's text, the scene, when). A
run whose pause is cached copies both to its output and continues them, as ``resume=True`` does: the
run loop's bitwise continuation, so its frames, series and results equal, bit for bit, those of the
run that settled itself. A run whose pause is not cached runs it into its own output (an interrupted
pause is resumed as any run), copies it into a new entry, and continues the same way. The run file
says which entry it started from (root attributes ``settled_state_key``, ``settled_state_path`` and
``settled_state_event``: ``settled`` if this run made the entry, ``from_cache`` if it found it).

Where: ``$TERRASPH_CACHE_DIR`` if set, else the platform's user cache directory
(``platformdirs.user_cache_dir("terrasph")``), under ``settled/``. ``terrasph cache list`` shows the
entries, ``terrasph cache clear`` removes them. Concurrency: an entry is written into a private
temporary directory and renamed into place in one step (a reader sees a whole entry or none); a lock
file per key makes a second process that wants the same entry wait for the first and then use it,
so a sweep's workers settle each bed once.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import fcntl
import hashlib
import json
import logging
import os
import pathlib
import shutil
import tempfile
import uuid
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["CACHE_ENV", "SettleCache", "SettledStart", "cache_key", "code_identity", "copy_start", "default_cache",
           "key_text", "model_digest", "pre_drive_fields", "record_start", "run_after_pause"]

LOG = logging.getLogger(__name__)

#: the environment variable that moves the cache (default: the platform's user cache directory)
CACHE_ENV = "TERRASPH_CACHE_DIR"
RUN_FILE = "pause.h5"
ENTRY_FILE = "entry.json"


def pre_drive_fields(config: Any) -> dict[str, Any]:
    """The fields of a configuration dataclass that shape the state before the drive: every field but
    those its class declares in ``DRIVE_FIELDS`` (which must name fields of it)."""
    drive = tuple(getattr(type(config), "DRIVE_FIELDS", ()))
    names = {f.name for f in dataclasses.fields(config)}
    unknown = sorted(set(drive) - names)
    if unknown:
        raise TypeError(f"{type(config).__name__}.DRIVE_FIELDS names {unknown}, which are not its fields")
    return {name: value for name, value in dataclasses.asdict(config).items() if name not in drive}


def code_identity() -> str:
    """SHA-256 of the package's Python sources and its compiled core (the core build's identity): a
    changed line of code makes every key new."""
    import terrasph
    from terrasph import _core

    package = pathlib.Path(terrasph.__file__).parent
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")) + [pathlib.Path(_core.__file__)]:
        digest.update(str(path.relative_to(package) if path.is_relative_to(package) else path.name).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def model_digest(model: Any) -> str:
    """SHA-256 of a compiled MuJoCo model (its MJB bytes): the robot as the run has it, whatever file
    or text it came from."""
    import mujoco
    import numpy as np

    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return hashlib.sha256(buffer.tobytes()).hexdigest()


def key_text(scene: str, config: Any, description: Mapping[str, Any], versions: Mapping[str, str],
             robot: str) -> str:
    """The canonical JSON of everything that determines the state at the end of `scene`'s pause:
    `config`'s pre-drive fields, the coupling's `description` (material, numerics, bodies, walls),
    the `versions`, the `robot` (:func:`model_digest`: a model file edited under the same name
    changes it) and the code's identity."""
    content = {"scene": scene, "config_type": type(config).__qualname__, "config": pre_drive_fields(config),
               "description": description, "versions": dict(versions), "robot": robot, "code": code_identity()}
    return json.dumps(content, sort_keys=True, default=_plain)


def cache_key(text: str) -> str:
    """The key of an entry: the SHA-256 of its :func:`key_text`."""
    return hashlib.sha256(text.encode()).hexdigest()


def _plain(value: Any) -> Any:
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot put {type(value).__name__} into a cache key")


@dataclass(frozen=True)
class SettledStart:
    """A cached pause a run starts from: its key, its entry's directory, and whether this run made it
    (``settled``) or found it (``from_cache``)."""

    key: str
    path: pathlib.Path
    event: str


class SettleCache:
    """The entries under `root` (module docstring)."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = pathlib.Path(root)

    def entry(self, key: str) -> pathlib.Path:
        """The directory of the entry of `key` (whether or not it exists)."""
        return self.root / key

    def start(self, key: str, text: str, output: str | os.PathLike[str], settle: Callable[[], None]) -> SettledStart:
        """Puts the pause of `key` into `output` (a run file, its checkpoint beside it): copied from
        the entry if there is one, else run by ``settle()`` into `output` and then copied into a new
        entry (written in a private directory, renamed into place; `text` is the key's content). One
        process at a time per key (a lock file): a second one waits, then finds the entry. A run
        interrupted during its pause is a run like any other (its file and checkpoint in `output`)."""
        self.root.mkdir(parents=True, exist_ok=True)
        with self._locked(key):
            final = self.entry(key)
            if (final / ENTRY_FILE).is_file():
                copy_start(final / RUN_FILE, output)
                LOG.info("terrasph: started from the cached settled state %s", final)
                return SettledStart(key, final, "from_cache")
            settle()
            try:
                self._publish(key, text, output)
            except OSError as error:  # a full disk, say: this run goes on without caching its pause
                LOG.warning("terrasph: could not cache the settled state in %s: %s", final, error)
            else:
                LOG.info("terrasph: settled the pause and cached it as %s", final)
            return SettledStart(key, final, "settled")

    def _publish(self, key: str, text: str, output: str | os.PathLike[str]) -> None:
        """A new entry of `key` holding the pause in `output`: copied into a private directory with
        its entry.json, then renamed into place in one step."""
        final = self.entry(key)
        staging = self.root / f".{key}.{os.getpid()}.{uuid.uuid4().hex}.tmp"
        staging.mkdir()
        try:
            copy_start(output, staging / RUN_FILE)
            (staging / ENTRY_FILE).write_text(json.dumps(
                {"key": key, "created_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                 "content": json.loads(text)}, indent=1, sort_keys=True))
            if final.exists():  # an incomplete entry (no entry.json), left by a crash
                shutil.rmtree(final)
            os.rename(staging, final)
        finally:
            shutil.rmtree(staging, ignore_errors=True)

    @contextlib.contextmanager
    def _locked(self, key: str) -> Iterator[None]:
        descriptor = os.open(self.root / f".{key}.lock", os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX)
            yield
        finally:
            os.close(descriptor)  # releases the lock

    def entries(self) -> list[dict[str, Any]]:
        """Every complete entry: key, path, size in bytes, creation time, scene and the pause's length."""
        rows = []
        for entry in sorted(self.root.glob("*/" + ENTRY_FILE)) if self.root.is_dir() else []:
            if entry.parent.name.startswith("."):  # a private directory being published
                continue
            record = json.loads(entry.read_text())
            content = record.get("content", {})
            config = content.get("config", {})
            rows.append({"key": record["key"], "path": str(entry.parent), "created_utc": record.get("created_utc"),
                         "bytes": sum(p.stat().st_size for p in entry.parent.iterdir()), "scene": content.get("scene"),
                         "settle_time": config.get("settle_time"), "spacing": config.get("spacing")})
        return rows

    def clear(self) -> int:
        """Removes every entry (and any left-over temporary directory or lock); returns how many entries."""
        count = len(self.entries())
        if self.root.is_dir():
            for path in self.root.iterdir():
                if path.is_dir():
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    path.unlink(missing_ok=True)
        return count


def default_cache() -> SettleCache:
    """The cache at ``$TERRASPH_CACHE_DIR`` or the platform's user cache directory, ``settled/``."""
    root = os.environ.get(CACHE_ENV)
    if not root:
        import platformdirs

        root = platformdirs.user_cache_dir("terrasph")
    return SettleCache(pathlib.Path(root) / "settled")


def record_start(output: str | os.PathLike[str], start: SettledStart, config: Mapping[str, Any]) -> None:
    """Makes the copied pause's run file `output` this run's: its configuration, its creation time, and
    which cached state it started from."""
    import h5py

    from terrasph.io import _json_default

    with h5py.File(output, "r+") as file:
        file.attrs["config_json"] = json.dumps(dict(config), sort_keys=True, default=_json_default)
        file.attrs["created_utc"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        file.attrs["settled_state_key"] = start.key
        file.attrs["settled_state_path"] = str(start.path)
        file.attrs["settled_state_event"] = start.event


def copy_start(source: str | os.PathLike[str], target: str | os.PathLike[str]) -> None:
    """Copies the run file `source` and its checkpoint to `target` and its checkpoint path, each through
    a temporary file renamed into place; ConfigError if `source` has no checkpoint."""
    from terrasph.config import ConfigError
    from terrasph.run_loop import checkpoint_path

    if not checkpoint_path(source).is_file():
        raise ConfigError(f"the settled state {source} has no checkpoint {checkpoint_path(source).name}: "
                          "remove it (terrasph cache clear)")
    for origin, destination in ((checkpoint_path(source), checkpoint_path(target)), (source, target)):
        destination = pathlib.Path(destination)
        temporary = destination.with_name(f".{destination.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
        try:
            shutil.copyfile(origin, temporary)  # created as any file the user writes (umask), not 0600
            os.replace(temporary, destination)
        finally:
            temporary.unlink(missing_ok=True)


def run_after_pause(cache: SettleCache | bool, scene: str, config: Any, terrain: Any, build: Callable[[], Any],
                    run: Callable[[Any, float, pathlib.Path | None, bool], Any], output: str | os.PathLike[str] | None,
                    run_config: Mapping[str, Any], settle_time: float, t_end: float) -> tuple[Any, Any, SettledStart]:
    """Runs a robot scene to `t_end` from the cached state at the end of its pause (`settle_time`),
    settling it into `output` first and caching it if it is not cached: ``run(terrain, t_end, output,
    resume)`` is the scene's run (returning its series), `terrain` the scene built (a
    :class:`terrasph.terrain.Terrain`; it runs the pause on a miss), `build` builds another (the run continues on a fresh one from the pause's
    checkpoint). `cache`: a SettleCache, True for :func:`default_cache`. `output` None: the run goes
    into a temporary file, removed after.
    Returns the run's series, the terrain that ran to `t_end` and the start."""
    import mujoco

    from terrasph.simulation import versions

    store = default_cache() if cache is True else cache
    if not isinstance(store, SettleCache):
        raise TypeError(f"parameter 'cache' = {cache!r}: allowed True (the default cache) or a SettleCache")
    text = key_text(scene, config, terrain.coupling.describe(), {**versions(), "mujoco": mujoco.__version__},
                    model_digest(terrain.model))
    key = cache_key(text)
    with contextlib.ExitStack() as stack:
        if output is None:
            output = pathlib.Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="terrasph-run-"))) / "run.h5"
        start = store.start(key, text, output, lambda: run(terrain, settle_time, pathlib.Path(output), False))
        record_start(output, start, run_config)
        continued = build()
        return run(continued, t_end, pathlib.Path(output), True), continued, start
