"""Run the h2h-racing CLI with an older policies/racing_line.py patched in (the "old" runs).

    git show 6ad01ea~1:policies/racing_line.py > /tmp/old_racing_line.py
    python old_racing_line_cli.py /tmp/old_racing_line.py evaluate --policy racing_line \
        --track ../shared/data/deepracer_tracks --episodes 10 --jobs 1 --json X.json

Every module's reference to compute_race_line, reference_lap_time, min_curvature_offsets and
RaceLine is swapped for the old file's; --jobs 1 keeps the run in this process (spawned
workers would import the new module). The old runs here were made before 8081587, so
racing_line's pursuit target was also the old one (track.point_at(s, offset)).
"""
import sys
import types

import h2h_racing.cli.command as command
import h2h_racing.policies  # noqa: F401
import h2h_racing.policies.racing_line as new
import h2h_racing.training.evaluate_routes  # noqa: F401

old = types.ModuleType("old_racing_line")
old.__file__ = sys.argv[1]
sys.modules["old_racing_line"] = old
with open(old.__file__) as f:
    exec(compile(f.read(), old.__file__, "exec"), old.__dict__)
swapped = 0
for mod in list(sys.modules.values()):
    for name in ("compute_race_line", "reference_lap_time", "min_curvature_offsets", "RaceLine"):
        if mod is not None and getattr(mod, name, None) is getattr(new, name):
            setattr(mod, name, getattr(old, name))
            swapped += 1
print(f"old racing_line patched into {swapped} places", file=sys.stderr)
sys.argv = ["h2h-racing"] + sys.argv[2:]
sys.exit(command.main())
