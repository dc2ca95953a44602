"""Physical-group names (the only place they are spelled out)."""

__all__ = [
    "BAR_LEFT",
    "BAR_LEFT_END",
    "BAR_RIGHT",
    "BAR_RIGHT_END",
    "BEAM_CLAMPED",
    "BEAM_PART_A",
    "BEAM_PART_B",
    "BEAM_TIP",
    "BLOCK",
    "BLOCK_BOTTOM",
    "BLOCK_TOP",
    "CRANE_FLANGE_SURFACES",
    "CRANE_SURFACES",
    "CRANE_VOLUMES",
]

# Split bar: cells left / right of model.split, and its two end points.
BAR_LEFT = "left"
BAR_RIGHT = "right"
BAR_LEFT_END = "left_end"
BAR_RIGHT_END = "right_end"

# Box beam: volume before / after the split plane, clamped face x = 0, loaded tip face x = L.
BEAM_PART_A = "part_a"
BEAM_PART_B = "part_b"
BEAM_CLAMPED = "clamped"
BEAM_TIP = "tip"

# Block on a plane: its one cell group, the face on the plane (z = gap) and the top face.
BLOCK = "block"
BLOCK_BOTTOM = "bottom"
BLOCK_TOP = "top"

# Crane mock-up, in the order of its physical groups (and so of their tags, from 1): volumes,
# then surfaces. A wheel's groups end in its number k = 1..4.
CRANE_VOLUMES = ["bridge_implicit", "trolley_frame"] + [
    f"{p}_{k}" for k in range(1, 5) for p in ("zone", "wheel")
]
CRANE_SURFACES = ["clamped"] + [f"{p}_patch_{k}" for p in ("wheel", "rail") for k in range(1, 5)]
#: The surface groups of a crane with flanges (after those of every crane): the inner faces of
#: the flanges below the rail top, ``flange_patch_{in,out}_k``, and the rail side patches facing
#: them, ``rail_side_patch_{in,out}_k``. ``in``: the flange between the rail and the crane's
#: centre plane x = 0 (a mirror image of an inner flange is an inner flange); the wheel number
#: last, as in every group of a wheel.
CRANE_FLANGE_SURFACES = [
    f"{p}_{side}_{k}"
    for p in ("flange_patch", "rail_side_patch")
    for side in ("in", "out")
    for k in range(1, 5)
]
