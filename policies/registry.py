"""Driver specs: a driver named with its settings, and ``make_driver``, which builds it.

Wherever a driver is named (``make_driver``, ``race --drivers``, ``evaluate --policy``,
``--against``, ``--field`` and ``--baseline``, ``tournament --players``, ``train --opponents``,
``[imitation]``'s ``driver`` and ``teacher``, a league's ``anchors``), a scripted driver may
carry settings after its name, each ``:SETTING=VALUE``::

    racing_line
    racing_line:grip_factor=0.7
    racing_line:grip_factor=0.7:margin=0.1
    blocker:lane=outer:cruise_speed=2.5

``:`` separates the settings because ``,`` already separates the drivers of a list
(``--against racing_line,racing_line:grip_factor=0.7``). Values are numbers or, for a
setting with named choices, one of its words; nothing is evaluated (``float`` or a word
compared with the choices), so a spec runs no code. Trained policies (a shipped name such as
``league_racer`` or a ``policy.pt`` path) take no settings.

**Declaring settings.** A scripted driver class lists the settings users may give in a class
attribute ``SETTINGS``, a dict from constructor keyword to :class:`Setting` (its allowed
range and a help line), in the order specs are written back::

    class Planner:
        name = "planner"
        SETTINGS = {
            "grip_factor": Setting(0.0, 1.0, "fraction of mu g used in corners",
                                   low_open=True),
        }

and is registered under its ``name`` in ``h2h_racing.policies.scripted.DRIVERS``. A
setting not in ``SETTINGS``, a value out of range or not a number, gives a ``ValueError``
of one line naming the driver, the setting and what is allowed. The driver ``make_driver``
builds gets its spec as ``name`` (``racing_line:grip_factor=0.7``; settings in
``SETTINGS``' order, numbers in their shortest form), so results tables and tournaments show
which pace raced; ``name`` must therefore be a plain class attribute.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

if TYPE_CHECKING:
    from h2h_racing.policies.scripted import Driver

SEPARATOR = ":"
"""Separates a driver's name from its settings, and each setting from the next."""


@dataclass(frozen=True)
class Setting:
    """A setting users may give a scripted driver in its spec: a number in ``[low, high]``
    (ends open with ``low_open`` / ``high_open``; None for no bound), an integer with
    ``integer``, or one of ``choices`` (words).

    >>> Setting(0.0, 1.0, "fraction of mu g", low_open=True).allowed()
    'a number in (0, 1]'
    >>> Setting(0.0, None, "gap [m]").allowed()
    'a number >= 0'
    >>> Setting(None, None, "lane", choices=("inner", "outer")).allowed()
    'one of inner, outer'
    """

    low: float | None
    """Lowest value (None: no lower bound)."""
    high: float | None
    """Highest value (None: no upper bound)."""
    help: str
    """What the setting does, with its unit."""
    low_open: bool = False
    """``low`` itself is not allowed."""
    high_open: bool = False
    """``high`` itself is not allowed."""
    integer: bool = False
    """Only whole numbers."""
    choices: tuple[str, ...] = ()
    """The allowed words of a setting that is not a number."""
    needs: str = ""
    """Another setting of the driver this one only works with (its constructor refuses it
    alone, saying so); empty: none."""

    def allowed(self) -> str:
        """What the setting takes, in words (``a number in (0, 1]``)."""
        if self.choices:
            return "one of " + ", ".join(self.choices)
        kind = "an integer" if self.integer else "a number"
        low, high = self.low, self.high
        if low is not None and high is not None:
            return (f"{kind} in {'(' if self.low_open else '['}{low:g}, {high:g}"
                    f"{')' if self.high_open else ']'}")
        if low is not None:
            return f"{kind} {'>' if self.low_open else '>='} {low:g}"
        if high is not None:
            return f"{kind} {'<' if self.high_open else '<='} {high:g}"
        return kind

    def value(self, text: str) -> float | int | str:
        """The value written ``text`` (stripped), checked; ``ValueError(self.allowed())``
        when it is not allowed."""
        text = text.strip()
        if self.choices:
            if text not in self.choices:
                raise ValueError(self.allowed())
            return text
        try:
            number = float(text)
        except ValueError:
            raise ValueError(self.allowed()) from None
        return self.check(number)

    def check(self, number: Any) -> float | int:
        """``number`` if this numeric setting allows it (a real number, not a bool, finite, in
        range; whole with ``integer``), as a float or int; ``ValueError(self.allowed())``
        otherwise. A constructor checks its keyword arguments with it, as specs are."""
        if isinstance(number, bool) or not isinstance(number, (int, float)):
            raise ValueError(self.allowed())
        number = float(number)
        if not math.isfinite(number) or (self.integer and not number.is_integer()):
            raise ValueError(self.allowed())
        low, high = self.low, self.high
        if low is not None and (number < low or (self.low_open and number == low)):
            raise ValueError(self.allowed())
        if high is not None and (number > high or (self.high_open and number == high)):
            raise ValueError(self.allowed())
        return int(number) if self.integer else number


class DriverSpec(NamedTuple):
    """A driver named with its settings (``parse_driver_spec``)."""

    name: str
    """Registry name of a scripted driver, a shipped policy's name or a ``policy.pt`` path."""
    settings: dict[str, Any]
    """Checked setting values by constructor keyword (empty for a trained policy)."""

    @property
    def text(self) -> str:
        """The spec written back: the name, then each setting in the driver's ``SETTINGS``
        order, numbers in their shortest form.

        >>> parse_driver_spec("racing_line:margin=0.10:grip_factor=.7").text
        'racing_line:grip_factor=0.7:margin=0.1'
        """
        order = list(driver_settings(self.name)) if self.settings else []
        keys = sorted(self.settings, key=lambda k: order.index(k) if k in order else len(order))
        return SEPARATOR.join([self.name, *(f"{k}={_format(self.settings[k])}" for k in keys)])


def _format(value: Any) -> str:
    """A setting value as a spec writes it: ``0.7``, ``2``, ``1e-05``, ``outer``."""
    if isinstance(value, float):
        short = f"{value:g}"
        return short if float(short) == value else repr(value)
    return str(value)


def driver_settings(name: str) -> dict[str, Setting]:
    """The settings scripted driver ``name`` declares (its class's ``SETTINGS``; empty for a
    driver that declares none).

    Raises:
        ValueError: If ``name`` is not a scripted driver.
    """
    from h2h_racing.policies.scripted import DRIVERS

    if name not in DRIVERS:
        raise ValueError(f"{name!r} is not a scripted driver ({', '.join(sorted(DRIVERS))})")
    return dict(getattr(DRIVERS[name], "SETTINGS", {}))


def is_trained(name: str) -> bool:
    """Whether ``name`` (a spec's name part) names a trained policy: a ``policy.pt`` path or
    a shipped policy."""
    from h2h_racing.policies.trained import shipped_policies

    return name.endswith(".pt") or name in shipped_policies()


def parse_driver_spec(text: str) -> DriverSpec:
    """Split a driver spec ``NAME[:SETTING=VALUE[:SETTING=VALUE...]]`` and check it.

    ``NAME`` is a scripted driver (``h2h_racing.policies.scripted.DRIVERS``), whose settings
    are checked against its class's ``SETTINGS`` (see the module docstring for how a driver
    declares them), a shipped policy or a ``policy.pt`` path (a text ending in ``.pt`` is a
    path, ``:`` and all); trained policies take no settings. Nothing in ``text`` is
    evaluated.

    >>> parse_driver_spec("racing_line:grip_factor=0.7")
    DriverSpec(name='racing_line', settings={'grip_factor': 0.7})
    >>> parse_driver_spec("racing_line:grip_factor=1.5")
    Traceback (most recent call last):
    ...
    ValueError: racing_line: grip_factor must be a number in (0, 1], got '1.5'

    Args:
        text: The spec, as written on the command line or in a config file.

    Returns:
        The name and the checked settings.

    Raises:
        ValueError: In one line, for an empty spec, an unknown driver, settings on a trained
            policy, a setting the driver does not declare, a setting given twice or without
            ``=VALUE``, or a value that is not allowed.
    """
    from h2h_racing.policies.scripted import DRIVERS
    from h2h_racing.policies.trained import shipped_policies

    if not isinstance(text, str):
        raise ValueError(f"a driver must be named by a string, got {text!r}")
    text = text.strip()
    if text.endswith(".pt"):
        return DriverSpec(text, {})
    name, *items = (part.strip() for part in text.split(SEPARATOR))
    if not name:
        raise ValueError(f"no driver name in {text!r}: write a driver (racing_line, "
                         f"league_racer, a policy.pt) with any settings after it, "
                         f"e.g. racing_line:grip_factor=0.7")
    if is_trained(name):
        if items:
            raise ValueError(f"{name}: a trained policy takes no settings, got "
                             f"{SEPARATOR.join(items)!r} (settings are for the scripted "
                             f"drivers: {', '.join(sorted(DRIVERS))})")
        return DriverSpec(name, {})
    if name not in DRIVERS:
        raise ValueError(f"unknown driver {name!r}; known drivers are "
                         f"{sorted(DRIVERS) + sorted(shipped_policies())} or the path of a "
                         f"policy.pt")
    declared = driver_settings(name)
    settings: dict[str, Any] = {}
    for item in items:
        key, equals, value = (part.strip() for part in item.partition("="))
        if not key or not equals:
            raise ValueError(f"{name}: setting {item!r} in {text!r} is not SETTING=VALUE; "
                             f"write e.g. {name}{SEPARATOR}"
                             f"{next(iter(declared), 'setting')}=VALUE")
        if key not in declared:
            known = (f"its settings are {', '.join(declared)}" if declared
                     else "it takes no settings")
            raise ValueError(f"{name}: unknown setting {key!r}; {known}")
        if key in settings:
            raise ValueError(f"{name}: {key} is given twice in {text!r}")
        try:
            settings[key] = declared[key].value(value)
        except ValueError as err:
            raise ValueError(f"{name}: {key} must be {err}, got {value!r}") from None
    return DriverSpec(name, settings)


def canonical_spec(text: str) -> str:
    """``text`` checked and written back (``DriverSpec.text``): two specs of the same driver
    and settings give the same text, e.g. for player names.

    >>> canonical_spec(" racing_line : grip_factor=0.70 ")
    'racing_line:grip_factor=0.7'
    """
    return parse_driver_spec(text).text


def make_driver(name: str, *, seed: int | None = None, **kwargs: Any) -> Driver:
    """Build a driver from its spec (a name, with any settings: see ``parse_driver_spec``).

    >>> make_driver("racing_line:grip_factor=0.7").grip_factor
    0.7
    >>> make_driver("pure_pursuit", cruise_speed=2.0).name
    'pure_pursuit:cruise_speed=2'

    Args:
        name: A scripted driver of ``DRIVERS`` (``"pure_pursuit"``, ``"racing_line"``,
            ``"blocker"``, ``"random"``; ``"random"`` needs ``seed`` or
            ``rng=np.random.default_rng(seed)``) with any of its ``SETTINGS``
            (``"racing_line:grip_factor=0.7"``), a shipped trained policy
            (``policies/trained/<name>/policy.pt``, e.g. ``"league_racer"``), or the path of a
            ``policy.pt`` (see ``h2h_racing.policies.trained``).
        seed: Seeds the ``random`` driver's generator when no ``rng`` is given (other
            drivers are deterministic and ignore it).
        **kwargs: Further constructor arguments of the driver (Python callers; the
            constructor checks them). Those that are declared settings show in its ``name``.

    Raises:
        ValueError: If the spec is not valid (``parse_driver_spec``), or a setting is given
            both in the spec and as a keyword.
    """
    import numpy as np

    from h2h_racing.policies.scripted import DRIVERS
    from h2h_racing.policies.trained import TrainedPolicy, shipped_policies

    spec = parse_driver_spec(name)
    if spec.name.endswith(".pt"):
        return TrainedPolicy(spec.name, **kwargs)
    shipped = shipped_policies()
    if spec.name in shipped:
        return TrainedPolicy(shipped[spec.name], name=spec.name, **kwargs)
    twice = sorted(set(spec.settings) & set(kwargs))
    if twice:
        raise ValueError(f"{spec.name}: {', '.join(twice)} given both in the spec {name!r} and "
                         f"as keyword arguments")
    if spec.name == "random" and "rng" not in kwargs:
        if seed is None:
            raise ValueError("the random driver needs a generator: make_driver('random', "
                             "seed=N) or make_driver('random', rng=np.random.default_rng(N))")
        kwargs["rng"] = np.random.default_rng(seed)
    driver = DRIVERS[spec.name](**spec.settings, **kwargs)
    declared = driver_settings(spec.name)
    shown = {**spec.settings, **{k: v for k, v in kwargs.items() if k in declared}}
    if shown:
        driver.name = DriverSpec(spec.name, shown).text
    return driver
