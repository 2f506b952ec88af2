"""The command's help pages: every option explained, every default shown, no source markup."""

from __future__ import annotations

import argparse
import re

import pytest

from h2h_racing.cli.command import build_parser
from h2h_racing.cli.help import HelpFormatter, walk_parsers

PARSERS = walk_parsers(build_parser())


def _options(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions
            if not isinstance(a, (argparse._HelpAction, argparse._SubParsersAction))]


def _shown_help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """The action's help text as the help page prints it (defaults expanded)."""
    return parser._get_formatter()._expand_help(action)


def test_the_walk_reaches_every_command() -> None:
    commands = {name for name, _ in PARSERS}
    assert {"h2h-racing race", "h2h-racing train", "h2h-racing evaluate", "h2h-racing camera",
            "h2h-racing tracks list", "h2h-racing tracks import", "h2h-racing tournament",
            "h2h-racing league train", "h2h-racing league table",
            "h2h-racing league plot"} <= commands
    assert all(isinstance(p._get_formatter(), HelpFormatter) for _, p in PARSERS)


@pytest.mark.parametrize(("command", "parser"), PARSERS, ids=[name for name, _ in PARSERS])
def test_every_option_has_help_and_shows_its_default(command: str, parser) -> None:
    assert parser.description, f"{command} has no description line"
    for action in _options(parser):
        name = "/".join(action.option_strings) or action.dest
        assert action.help, f"{command} {name} has no help text"
        default = action.default
        if any(default is off for off in (None, False, argparse.SUPPRESS)):
            continue
        shown = _shown_help(parser, action)
        value = ",".join(default) if isinstance(default, tuple) else str(default)
        assert f"default: {value})" in shown, f"{command} {name}: {shown!r} hides {value!r}"


def test_top_level_help_is_plain_text() -> None:
    text = build_parser().format_help()
    assert "``" not in text and ".py" not in text and "README" not in text, text
    assert "league train --config recommended" in text  # the examples name the recipe


@pytest.mark.parametrize("name", ["--tracks"])
def test_a_comma_list_default_reads_as_typed(name: str) -> None:
    parser = dict(PARSERS)["h2h-racing tournament"]
    action = next(a for a in parser._actions if name in a.option_strings)
    assert action.default == "speedway"  # a string: argparse applies type= to it
    assert build_parser().parse_args(["tournament", "--players", "a,b"]).tracks == ("speedway",)


def test_train_options_state_the_defaults_train_uses() -> None:
    """Passing the default a ``train`` option's help names changes nothing: the help of options
    that default to the config file's value (None here) tells the truth."""
    pytest.importorskip("torch")
    from h2h_racing.training.cli import _train_config

    parser = build_parser()
    base = _train_config(parser.parse_args(["train", "--out", "x"]))
    train = dict(PARSERS)["h2h-racing train"]
    checked = []
    for action in _options(train):
        match = re.search(r"\(default: ([A-Za-z0-9_.]+)[,)]", action.help or "")
        if action.default is not None or match is None:
            continue
        value = match.group(1)
        if value == "none" and "'none'" not in action.help:
            continue  # "none": the option is off (no --init, no --teacher)
        flag = action.option_strings[0]
        given = _train_config(parser.parse_args(["train", "--out", "x", flag, value]))
        assert given == base, f"train {flag} {value} is not the default"
        checked.append(flag)
    assert {"--track", "--obs", "--rules", "--envs", "--seed", "--eval-every"} <= set(checked)


def test_the_drivers_help_names_every_shipped_driver() -> None:
    from h2h_racing.cli.help import DRIVERS_HELP
    from h2h_racing.policies import DRIVERS
    from h2h_racing.policies.trained import shipped_policies

    for name in [*DRIVERS, *shipped_policies()]:
        assert name in DRIVERS_HELP, f"--drivers' help does not name {name}"
