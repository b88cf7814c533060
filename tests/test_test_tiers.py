"""The README's test command is the fast suite; `.ci/run` adds the slow validation but not the long
studies (a new user checking an install must not wait an hour).

Budgets on this 2-core machine: the README command within 15 min, `.ci/run` within 45 min. The
durations come from docs/benchmarks.md; what is checked here is the structure that keeps them:
which command runs which tier, and that every study of tens of minutes is opt-in.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def readme_test_command() -> str:
    """The single pytest command line of the README's "Run the test suite" block."""
    readme = (ROOT / "README.md").read_text()
    commands = [line for block in re.findall(r"```bash\n(.*?)```", readme, re.S)
                for line in block.splitlines() if "pytest" in line]
    assert len(commands) == 1, commands
    return commands[0].strip()


def test_readme_test_command_is_the_fast_suite() -> None:
    command = readme_test_command()
    assert command.endswith("python -m pytest -q tests")
    assert "--runslow" not in command and "--runlong" not in command


def test_ci_runs_the_readme_command_then_the_slow_tier_only() -> None:
    script = (ROOT / ".ci" / "run").read_text()
    lines = [line.strip() for line in script.splitlines() if line.strip() and not line.startswith("#")]
    assert readme_test_command() in lines
    pytest_lines = [line for line in lines if "pytest" in line]
    assert any("--runslow" in line for line in pytest_lines)
    assert not any("--runlong" in line for line in pytest_lines)
    assert "TERRASPH_RUN_LONG" not in script


def test_leg_sweeps_at_the_slow_speed_are_opt_in() -> None:
    """The 0.2 rad/s leg runs (9–20 min each) are `long`; CI keeps the 0.8 rad/s trio (~2.5 min each)."""
    import test_leg_rotation as legs

    marks = {tuple(case.values): {m.name for m in case.marks} for case in legs.CASES}
    assert all(marks[case] == {"slow"} for case in marks if case[1] == 0.8)
    assert all(marks[case] == {"long"} for case in marks if case[1] == 0.2)
    assert len([case for case in marks if case[1] == 0.8]) == 3
    for name in ("test_faster_rotation_lifts_more_and_thrust_is_rate_independent",
                 "test_chapter_3_rate_dependence_returns_with_the_dissertations_artificial_viscosity"):
        assert "long" in {m.name for m in getattr(getattr(legs, name), "pytestmark", [])}


def test_long_tests_are_skipped_under_runslow(pytester: pytest.Pytester) -> None:
    """--runslow runs `slow` and skips `long`; --runlong runs both."""
    pytester.makeconftest((ROOT / "tests" / "conftest.py").read_text())
    pytester.makepyfile(test_tiers="""
        import pytest

        @pytest.mark.slow
        def test_slow():
            pass

        @pytest.mark.long
        def test_long():
            pass

        def test_fast():
            pass
    """)
    pytester.runpytest().assert_outcomes(passed=1, skipped=2)
    pytester.runpytest("--runslow").assert_outcomes(passed=2, skipped=1)
    pytester.runpytest("--runlong").assert_outcomes(passed=3)
