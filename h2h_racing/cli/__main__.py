"""``python -m h2h_racing.cli``: the h2h-racing command."""

import sys

from h2h_racing.cli.command import main

sys.exit(main())
