"""Deprecated: ``h2h_racing.env`` the module is now ``h2h_racing.envs.parallel``;
the old path goes in the next release. ``h2h_racing.env(...)``, the PettingZoo AEC factory, stays.

Importing this module sets the package's ``env`` attribute to it (the import system does), so
the module is callable too: ``h2h_racing.env(...)`` keeps making the AEC env either way.
"""

import sys
import types
import warnings
from typing import Any

from h2h_racing.envs import parallel as _parallel

warnings.warn("h2h_racing.env (the module) is now h2h_racing.envs.parallel; the old path goes "
              "in the next release: import h2h_racing.envs.parallel (h2h_racing.env(...) "
              "stays)", DeprecationWarning, stacklevel=2)


class _EnvModule(types.ModuleType):
    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return _parallel.env(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        return getattr(_parallel, name)


sys.modules[__name__].__class__ = _EnvModule
