"""Step 10's teacher at the tight boxes: ``../step9_obstacle/teacher_margin.py`` (imported: the
same 20 waist tracks, races and measure) on the teacher with ``box_edge = 0`` held to boxes
with under 0.24 m of room (``box_edge_room``). Step 9's figures for the card's teacher (12.7 cm)
and ``box_edge = 0`` everywhere (15.9 cm) are in its ``teacher_margin.txt``.

    python experiments/routes/retrain/step10_obstacle/teacher_margin.py --tracks 20
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

HERE = Path(__file__).resolve().parent
_SPEC = importlib.util.spec_from_file_location(
    "teacher_margin9", HERE.parent / "step9_obstacle" / "teacher_margin.py")
MARGIN = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(MARGIN)

if __name__ == "__main__":
    MARGIN.VARIANTS = {"edge 0.0 under 0.24 m":
                       MARGIN.TEACHER + ",box_edge=0.0,box_edge_room=0.24"}
    MARGIN.main()
