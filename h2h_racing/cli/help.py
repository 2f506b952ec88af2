"""Help pages of the ``h2h-racing`` command: every option shows its default, every
subcommand opens with a description line.

``ArgumentParser`` below is the parser class of the command and, through ``add_subparsers``,
of every subcommand, so a subcommand added anywhere (``h2h_racing.league.cli``) gets the
same help without passing a formatter around.
"""

from __future__ import annotations

import argparse
import shlex
from typing import Any

DESCRIPTION = "Race, train and rate cars on DeepRacer-style tracks."
EPILOG = """examples:
  h2h-racing race --track speedway --drivers league_racer,racing_line --save race.rrd
  h2h-racing evaluate --policy league_racer --against racing_line --track all --races 10
  h2h-racing train --track speedway --minutes 10 --out runs/speedway
  h2h-racing league train --config recommended    # 30 minutes; --config smoke: under a minute

Run 'h2h-racing COMMAND --help' for a command's options."""
DRIVERS_HELP = ("comma-separated drivers, one per car: scripted (planner, racing_line, "
                "pure_pursuit, blocker, random), shipped policies (league_racer, ppo_generalist, "
                "obstacle_generalist, camera_generalist, camera_racer, camera_speedway, "
                "racing_line_student) or policy.pt files; a scripted driver takes settings "
                "after its name, e.g. racing_line:grip_factor=0.7 for its pace ("
                "policies/README.md lists them)")
SPEC_HELP = ("a scripted driver takes settings after its name, e.g. racing_line:grip_factor=0.7 "
             "or racing_line:grip_factor=0.7:margin=0.1")
SEED_HELP = "random seed (start points, noise)"


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Appends ``(default: X)`` to an option's help when it has a default worth showing.

    Unlike ``argparse.ArgumentDefaultsHelpFormatter`` it says nothing for ``None`` and
    ``False`` defaults (an option that is off, or whose help says what happens without it)
    and keeps a help text that already names its default.
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        # Identity, not ==: 0 == False, and a 0 default is worth showing.
        if (action.option_strings and "default" not in text
                and not any(action.default is off for off in (None, False, argparse.SUPPRESS))):
            text += " (default: %(default)s)"
        return text


class _SubParsersAction(argparse._SubParsersAction):  # noqa: SLF001 - argparse's extension point
    """A subcommand's one-line ``help`` (shown in its parent's list) is also the description
    line of its own help page, unless it has its own ``description``."""

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser:
        text = kwargs.get("help")
        if text and "description" not in kwargs:
            kwargs["description"] = text[:1].upper() + text[1:] + "."
        return super().add_parser(name, **kwargs)


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` with ``HelpFormatter`` and described subcommands."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)
        self.register("action", "parsers", _SubParsersAction)


def walk_parsers(parser: argparse.ArgumentParser, prefix: str = ""
                 ) -> list[tuple[str, argparse.ArgumentParser]]:
    """``(command, parser)`` for ``parser`` and every subcommand below it, depth first."""
    found = [(prefix or parser.prog, parser)]
    for action in parser._actions:  # noqa: SLF001 - argparse keeps subparsers only here
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            for name, child in action.choices.items():
                found += walk_parsers(child, f"{prefix or parser.prog} {name}")
    return found


def command_line(args: argparse.Namespace, parser: argparse.ArgumentParser,
                 words: tuple[str, ...], replace: dict[str, Any] | None = None,
                 leave_out: tuple[str, ...] = ("progress",)) -> str:
    """The ``h2h-racing`` command line that runs ``args`` again: ``words`` (the command
    names), then every option of ``parser`` whose value differs from its default (``replace``
    overrides values first, a None value leaves the option out), shell-quoted.

    Tuple values (comma-separated lists) are joined with commas; a true ``store_true`` flag is
    written bare, a false ``--x/--no-x`` flag as ``--no-x``.
    """
    values = dict(vars(args), **(replace or {}))
    parts = ["h2h-racing", *words]
    for action in parser._actions:  # argparse has no public list of a parser's options
        if not action.option_strings or action.dest in leave_out or action.dest == "help":
            continue
        value = values.get(action.dest, action.default)
        if value is None or value == action.default:
            continue
        option = next(o for o in action.option_strings if o.startswith("--"))
        if isinstance(action, argparse.BooleanOptionalAction):
            parts.append(option if value else "--no-" + option[2:])
        elif action.nargs == 0:
            parts.append(option)
        else:
            text = ",".join(map(str, value)) if isinstance(value, (tuple, list)) else str(value)
            parts += [option, text]
    return shlex.join(parts)
