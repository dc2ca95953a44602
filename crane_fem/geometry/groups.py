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
