"""A frame of your own, scripted: a portal gantry (two columns clamped to the floor, a beam
across) with a hoist trolley on its beam (four wheels rolling on the beam's top flange) and a
500 kg load on a 1.5 m rope. Writes gantry.msh beside this script (`python gantry.py`).

Line groups (members): ``columns``, ``beam`` (the rail beam, split in ``beam`` and the
explicit ``runway`` under the trolley), ``trolley`` (the trolley's frame), ``rope``.
Point groups: ``feet`` (clamped), ``wheels`` (the trolley's four wheels, on the beam's top),
``load`` (the hanging mass)."""

from pathlib import Path

from crane_fem.geometry.frame_sketch import FrameSketch

SPAN, HEIGHT = 6.0, 4.0
BEAM_DEPTH = 0.3  # the wheels run on the beam's top: 0.15 m above its axis
X_TROLLEY, WHEEL_BASE = 2.5, 0.6

s = FrameSketch()
for x in (0.0, SPAN):
    s.member("columns", (x, 0.0, 0.0), (x, 0.0, HEIGHT), size=0.25)
s.member("beam", (0.0, 0.0, HEIGHT), (1.8, 0.0, HEIGHT), size=0.25)
s.member("runway", (1.8, 0.0, HEIGHT), (3.2, 0.0, HEIGHT), size=0.1)
s.member("beam", (3.2, 0.0, HEIGHT), (SPAN, 0.0, HEIGHT), size=0.25)
top = HEIGHT + 0.5 * BEAM_DEPTH
# Four wheels, two each side of the beam's web, 50 mm off its axis on its top flange.
x0, x1 = X_TROLLEY - 0.5 * WHEEL_BASE, X_TROLLEY + 0.5 * WHEEL_BASE
wheels = [(x, y, top) for x in (x0, x1) for y in (-0.05, 0.05)]
for y in (-0.05, 0.05):
    s.member("trolley", (x0, y, top), (x1, y, top), elements=4)
for x in (x0, X_TROLLEY, x1):
    s.member("trolley", (x, -0.05, top), (x, 0.05, top), elements=2)
s.member("rope", (X_TROLLEY, 0.0, top), (X_TROLLEY, 0.0, top - 1.5), elements=1)
s.points("feet", [(0.0, 0.0, 0.0), (SPAN, 0.0, 0.0)])
s.points("wheels", wheels)
s.points("load", [(X_TROLLEY, 0.0, top - 1.5)])

if __name__ == "__main__":
    out = s.write(Path(__file__).with_name("gantry.msh"))
    print(f"wrote {out}")
