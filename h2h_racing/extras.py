"""Deprecated: ``h2h_racing.extras`` is now ``h2h_racing.common.extras``;
the old path goes in the next release."""

import importlib
import sys
import warnings

warnings.warn("h2h_racing.extras is now h2h_racing.common.extras; "
              "the old path goes in the next release: import h2h_racing.common.extras",
              DeprecationWarning, stacklevel=2)
# The old name gives the new module itself: monkeypatches, private names and pickles
# keep working.
sys.modules[__name__] = importlib.import_module("h2h_racing.common.extras")
