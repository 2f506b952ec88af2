"""Tests for driver specs (:mod:`h2h_racing.policies.registry`): a driver named with its
settings, checked against what the driver declares, and built by ``make_driver``."""

from __future__ import annotations

import re

import numpy as np
import pytest

from h2h_racing.policies import (
    DRIVERS,
    Blocker,
    RacingLine,
    Setting,
    canonical_spec,
    make_driver,
    parse_driver_spec,
)
from h2h_racing.policies.registry import driver_settings


class TestSetting:
    """A setting's allowed values, in words and checked, with hand-picked edges."""

    def test_allowed_in_words(self) -> None:
        assert Setting(0.0, 1.0, "", low_open=True).allowed() == "a number in (0, 1]"
        assert Setting(0.0, 4.0, "", high_open=True).allowed() == "a number in [0, 4)"
        assert Setting(0.0, None, "").allowed() == "a number >= 0"
        assert Setting(None, 2.5, "", high_open=True).allowed() == "a number < 2.5"
        assert Setting(1, 10, "", integer=True).allowed() == "an integer in [1, 10]"
        assert Setting(None, None, "", choices=("inner", "outer")).allowed() == \
            "one of inner, outer"

    def test_values_at_the_edges(self) -> None:
        grip = Setting(0.0, 1.0, "", low_open=True)
        assert grip.value("1") == 1.0 and grip.value(" 0.25 ") == 0.25 and grip.value("1e-3") == 1e-3
        for bad in ("0", "-0.1", "1.0001", "nan", "inf", "1e400", "", "0.7x", "True"):
            with pytest.raises(ValueError, match=re.escape("a number in (0, 1]")):
                grip.value(bad)
        count = Setting(1, 10, "", integer=True)
        assert count.value("3") == 3 and isinstance(count.value("3.0"), int)
        with pytest.raises(ValueError):
            count.value("2.5")
        lane = Setting(None, None, "", choices=("inner", "outer"))
        assert lane.value("outer") == "outer"
        with pytest.raises(ValueError, match="one of inner, outer"):
            lane.value("middle")


class TestParse:
    """Good specs split into a name and checked settings; bad ones give one line naming the
    driver, the setting and what is allowed."""

    def test_plain_names(self) -> None:
        assert parse_driver_spec("racing_line") == ("racing_line", {})
        assert parse_driver_spec(" league_racer ") == ("league_racer", {})
        # A text ending in .pt is a path, colons and all.
        assert parse_driver_spec("runs/a:b/policy.pt") == ("runs/a:b/policy.pt", {})

    def test_settings(self) -> None:
        spec = parse_driver_spec("racing_line:grip_factor=0.7:margin=0.1")
        assert spec.name == "racing_line" and spec.settings == {"grip_factor": 0.7, "margin": 0.1}
        assert parse_driver_spec("blocker : lane = outer").settings == {"lane": "outer"}
        # Written back in the declared order, numbers in their shortest form.
        assert canonical_spec("racing_line:margin=0.100:grip_factor=.70") == \
            "racing_line:grip_factor=0.7:margin=0.1"
        assert canonical_spec("racing_line:grip_factor=1.0") == "racing_line:grip_factor=1"

    @pytest.mark.parametrize(("text", "message"), [
        ("racing_line:grip_factor=1.5",
         "racing_line: grip_factor must be a number in (0, 1], got '1.5'"),
        ("racing_line:grip_factor=0", "racing_line: grip_factor must be a number in (0, 1], got '0'"),
        ("racing_line:grip_factor=fast",
         "racing_line: grip_factor must be a number in (0, 1], got 'fast'"),
        ("racing_line:grip_factor=nan",
         "racing_line: grip_factor must be a number in (0, 1], got 'nan'"),
        ("pure_pursuit:cruise_speed=9", "pure_pursuit: cruise_speed must be a number in (0, 4], "
                                         "got '9'"),
        ("blocker:lane=middle", "blocker: lane must be one of inner, outer, got 'middle'"),
        ("racing_line:grp=0.7", "racing_line: unknown setting 'grp'; its settings are "
                                "grip_factor, margin, speed_preview,"),
        ("random:seed=3", "random: unknown setting 'seed'; it takes no settings"),
        ("racing_line:grip_factor=0.7:grip_factor=0.8", "racing_line: grip_factor is given twice"),
        ("racing_line:grip_factor", "racing_line: setting 'grip_factor' in "
                                    "'racing_line:grip_factor' is not SETTING=VALUE"),
        ("racing_line:", "racing_line: setting '' in 'racing_line:' is not SETTING=VALUE"),
        ("league_racer:grip_factor=0.7", "league_racer: a trained policy takes no settings, got "
                                         "'grip_factor=0.7'"),
        ("runs/x/policy.pt:grip_factor=0.7", "runs/x/policy.pt: a trained policy takes no "
                                             "settings"),
        ("", "no driver name in ''"),
        (":grip_factor=0.7", "no driver name in ':grip_factor=0.7'"),
        ("fast:grip_factor=0.7", "unknown driver 'fast'; known drivers are"),
    ])
    def test_refused_in_one_line(self, text: str, message: str) -> None:
        with pytest.raises(ValueError, match=re.escape(message)) as info:
            parse_driver_spec(text)
        assert "\n" not in str(info.value)

    def test_not_a_string(self) -> None:
        with pytest.raises(ValueError, match="must be named by a string"):
            parse_driver_spec(0.7)  # type: ignore[arg-type]


class TestMakeDriver:
    """make_driver builds the driver with the spec's settings and names it by its spec."""

    def test_racing_line_pace(self) -> None:
        driver = make_driver("racing_line:grip_factor=0.7")
        assert isinstance(driver, RacingLine)
        assert driver.grip_factor == 0.7 and driver.margin == 0.12  # the other at its default
        assert driver.name == "racing_line:grip_factor=0.7"
        assert make_driver("racing_line").name == "racing_line"
        assert RacingLine.name == "racing_line"  # the class keeps its registry name

    def test_several_settings_and_a_word(self) -> None:
        driver = make_driver("blocker:cruise_speed=2.5:lane=outer")
        assert isinstance(driver, Blocker)
        assert (driver.lane, driver.cruise_speed) == ("outer", 2.5)
        assert driver.name == "blocker:lane=outer:cruise_speed=2.5"

    def test_keywords_that_are_settings_show_in_the_name(self) -> None:
        assert make_driver("pure_pursuit", cruise_speed=2.0).name == "pure_pursuit:cruise_speed=2"
        # rng is a constructor argument, not a declared setting: not in the name.
        assert make_driver("random", rng=np.random.default_rng(0)).name == "random"

    def test_setting_given_twice(self) -> None:
        with pytest.raises(ValueError, match="grip_factor given both in the spec"):
            make_driver("racing_line:grip_factor=0.7", grip_factor=0.8)

    def test_random_still_needs_a_seed(self) -> None:
        with pytest.raises(ValueError, match="random driver needs a generator"):
            make_driver("random")
        assert make_driver("random", seed=1).name == "random"

    @pytest.mark.parametrize("name", sorted(DRIVERS))
    def test_every_declared_setting_builds(self, name: str) -> None:
        """Each driver's declared settings are constructor arguments it accepts at both ends
        of their range (so a declaration cannot promise what the constructor refuses)."""
        for key, setting in driver_settings(name).items():
            values = list(setting.choices) or [
                v for v, is_open in ((setting.low, setting.low_open),
                                     (setting.high, setting.high_open))
                if v is not None and not is_open]
            assert values, f"{name}.{key}: no closed end to try"
            # A setting that needs another (racing_line's box_edge_room: box_edge) is built
            # with that one at its low end, the closed end its range has.
            partner = ""
            if setting.needs:
                other = driver_settings(name)[setting.needs]
                partner = f"{setting.needs}={other.high if other.low_open else other.low}:"
            for value in values:
                spec = f"{name}:{partner}{key}={value}"
                driver = make_driver(spec, seed=0)
                assert getattr(driver, "name") == canonical_spec(spec)
