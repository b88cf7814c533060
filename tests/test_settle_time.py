"""One rule for a run's settling pause in every scene: a pause that lasts until the end time or
beyond (``--settle-time 3 --t-end 2``) would give a run that never drives, pushes or turns, with a
summary of nulls; every registered scene refuses it before any work, in one line naming the
option, exit 2 (as the ``mjcf`` scene always did), and a pause just shorter than the end is
accepted by the configuration."""

from __future__ import annotations

import dataclasses

import pytest
from terrasph.cli import main
from terrasph.config import ConfigError
from terrasph.robots import ROVER
from terrasph.scenes import SCENES, scene_entry

#: what a scene needs besides the two times (the mjcf scene its model)
REQUIRED = {"mjcf": [str(ROVER)]}


def _pause_option(scene: str) -> str:
    """The option that sets the scene's pause: --settle-time in every scene (tests/test_option_names.py)."""
    assert "settle_time" in {f.name for f in dataclasses.fields(scene_entry(scene).config_type)}
    return "--settle-time"


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_a_pause_until_the_end_is_refused_before_any_work(scene, tmp_path, capsys) -> None:
    out = tmp_path / "run.h5"
    with pytest.raises(SystemExit) as refused:
        main(["run", scene, *REQUIRED.get(scene, []), _pause_option(scene), "3", "--t-end", "2", "--out", str(out),
              "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert refused.value.code == 2, err
    assert len(err.splitlines()) == 1
    assert _pause_option(scene) in err and "t_end = 2" in err, err
    assert not out.exists()


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_a_pause_shorter_than_the_end_is_accepted(scene) -> None:
    entry = scene_entry(scene)
    name = _pause_option(scene)[2:].replace("-", "_")
    extra = {"model": str(ROVER)} if scene == "mjcf" else {}
    entry.config_from({**extra, name: 1.99, "t_end": 2.0})
    with pytest.raises(ConfigError, match=f"'{name}' = 2.0 is invalid"):
        entry.config_from({**extra, name: 2.0, "t_end": 2.0})
