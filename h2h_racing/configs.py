"""Deprecated: ``h2h_racing.configs`` is now ``h2h_racing.config.shipped``;
the old path goes in the next release."""

import importlib
import sys
import warnings

warnings.warn("h2h_racing.configs is now h2h_racing.config.shipped; "
              "the old path goes in the next release: import h2h_racing.config.shipped",
              DeprecationWarning, stacklevel=2)
# The old name gives the new module itself: monkeypatches, private names and pickles
# keep working.
sys.modules[__name__] = importlib.import_module("h2h_racing.config.shipped")
